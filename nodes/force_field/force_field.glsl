#version 330
// Curtis' force field (seed 004) from the seed's Sobel pair g = (gx, gy) of the blurred depth:
// ff1 = rot90(g), ff2 = rot90(sobel(tent9(min(|g|, clamp)))), ff = ff1 - ff2, rot90(x, y) = (-y, x).
// PASS 0: min(|g|, clamp) blurred along x by [1 2 3 4 5 4 3 2 1] / 25;  PASS 1: the same along y;
// PASS 2: h = Sobel of that, ff = ff1 - ff2 (RESTORING 1: ff2 = h unrotated, a pull up the magnitude
//         ridge, i.e. towards the edge), divided by max(|ff|, saturate) when saturate > 0.
// Borders clamp to the edge texel in every pass.
#if defined FRAGMENT_SHADER
#if PASS < 2
uniform sampler2D t_src;
uniform float u_clamp;
layout(location = 0) out float o_blur;

float value_at(ivec2 p, ivec2 hi) {
    vec4 s = texelFetch(t_src, clamp(p, ivec2(0), hi), 0);
#if PASS == 0
    return min(sqrt(s.x * s.x + s.y * s.y), u_clamp);
#else
    return s.r;
#endif
}

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    ivec2 hi = textureSize(t_src, 0) - 1;
#if PASS == 0
    ivec2 axis = ivec2(1, 0);
#else
    ivec2 axis = ivec2(0, 1);
#endif
    float sum = 0.0;
    for (int k = -4; k <= 4; ++k)
        sum += float(5 - abs(k)) * value_at(p + k * axis, hi);
    o_blur = sum / 25.0;
}
#else
#include "../depth_edges/seed_sobel.glsl"
uniform sampler2D t_gradient;
uniform sampler2D t_blur;
uniform float u_saturate;
layout(location = 0) out vec2 o_out;

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec2 g = texelFetch(t_gradient, p, 0).xy;
    vec2 h = seed_sobel(t_blur, p);
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
