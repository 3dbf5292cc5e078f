#version 330
// Curtis' force field (seed 004) from the seed's Sobel pair g = (gx, gy) of the blurred depth:
// ff1 = rot90(g), ff2 = rot90(sobel(tent9(min(|g|, clamp)))), ff = ff1 - ff2, rot90(x, y) = (-y, x).
// The 9x9 tent [1 2 3 4 5 4 3 2 1] / 25 (each axis) and the Sobel pair run as one separable pass per
// axis (../depth_edges/tent_sobel.glsl), edge-clamped at both stages as the two convolutions are; their
// footprint is in pixels at the reference size (TENT_R, SOBEL_R and the weights from px_scale,
// ../_shared/scaled_kernels.py; at px_scale 1 the seed's 9x9 tent and 3x3 Sobel):
// PASS 0 (along x): min(|g|, clamp), then (smooth, diff) of its tent along x.
// PASS 1 (along y): h = the Sobel pair of the blurred magnitude, ff = ff1 - ff2 (RESTORING 1: ff2 = h
//         unrotated, a pull up the magnitude ridge, i.e. towards the edge), divided by max(|ff|, saturate)
//         when saturate > 0.
// Split (wide kernels, ../depth_edges/tent_sobel.glsl): PASS 2 the magnitude's tent along x, PASS 3 and 4 the
// generic halves, PASS 5 PASS 1's field from the y tents.
#if defined FRAGMENT_SHADER
#include "../depth_edges/tent_sobel.glsl"
#if PASS == 0 || PASS == 2
uniform sampler2D t_gradient;
uniform float u_clamp;
layout(location = 0) out vec2 o_x;

vec2 magnitude_at(ivec2 p, ivec2 hi) {
    vec2 g = texelFetch(t_gradient, ivec2(clamp(p.x, 0, hi.x), p.y), 0).xy;
    return vec2(min(sqrt(g.x * g.x + g.y * g.y), u_clamp));
}

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    ivec2 hi = textureSize(t_gradient, 0) - 1;
#if PASS == 0
    vec2 w[2 * WIN_R + 1];
    for (int m = -WIN_R; m <= WIN_R; ++m)
        w[m + WIN_R] = magnitude_at(p + ivec2(m, 0), hi);
    o_x = tent_sobel_x(w, p.x, hi.x);
#else
    vec2 w[2 * TENT_R + 1];
    for (int j = -TENT_R; j <= TENT_R; ++j)
        w[j + TENT_R] = magnitude_at(p + ivec2(j, 0), hi);
    o_x = tent_of(w);
#endif
}
#elif PASS == 1 || PASS == 5
uniform sampler2D t_gradient;
uniform sampler2D t_x;  // PASS 1: the x pass; PASS 5: its y tents
uniform float u_saturate;
layout(location = 0) out vec2 o_out;

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
#if PASS == 1
    ivec2 hi = textureSize(t_x, 0) - 1;
    vec2 w[2 * WIN_R + 1];
    for (int m = -WIN_R; m <= WIN_R; ++m)
        w[m + WIN_R] = texelFetch(t_x, ivec2(p.x, clamp(p.y + m, 0, hi.y)), 0).xy;
    vec2 h = tent_sobel_y(w, p.y, hi.y) / u_tent_norm;
#else
    vec2 h = sobel_y_from(t_x, p) / u_tent_norm;
#endif
    vec2 g = texelFetch(t_gradient, p, 0).xy;
#if RESTORING == 1
    vec2 ff = vec2(-g.y, g.x) - h;
#else
    vec2 ff = vec2(-g.y, g.x) - vec2(-h.y, h.x);
#endif
    if (u_saturate > 0.0)
        ff /= max(sqrt(ff.x * ff.x + ff.y * ff.y), u_saturate);
    o_out = ff;
}
#endif
#endif
