#version 330
// Curtis' edge map (seed 004): 3x3 tent blur of the depth map, Sobel gradient, magnitude, threshold.
// The blur [1 2 1; 2 4 2; 1 2 1] / 16 and the seed's Sobel pair run as one separable pass per axis
// (tent_sobel.glsl), edge-clamped at both stages as the two convolutions are; with reference_height
// `pipeline` their footprint is in pixels at the reference size (TENT_R, SOBEL_R and the weights set by
// the node from px_scale, ../_shared/scaled_kernels.py), otherwise the seed's (TENT_R 1, SOBEL_R 1).
// PASS 0 (along x): depth in [0, 1] (1 = background; DEPTH_MODE 1 converts linear view depth,
//         0 = background, with the near and far planes), then (smooth, diff) of its tent along x.
// PASS 1 (along y): (gx, gy) = the seed's Sobel pair of the blurred depth times u_scale (height /
//         reference height: per pixel of an image of the reference height; 1 with scaled kernels), mag = |(gx, gy)|,
//         edge = mag >= threshold.
// Split (wide kernels, tent_sobel.glsl): PASS 2 the depth's tent along x, PASS 3 and 4 the generic halves, PASS 5
// PASS 1's outputs from the y tents.
#if defined FRAGMENT_SHADER
#include "tent_sobel.glsl"
#if PASS == 0 || PASS == 2
uniform sampler2D t_depth;
uniform vec2 u_range;  // linear depth mapped to 0 and 1
layout(location = 0) out vec2 o_x;

float depth_at(ivec2 p, ivec2 hi) {
    float z = texelFetch(t_depth, clamp(p, ivec2(0), hi), 0).r;
#if DEPTH_MODE == 1
    return z > 0.0 ? clamp((z - u_range.x) / (u_range.y - u_range.x), 0.0, 1.0) : 1.0;
#else
    return z;
#endif
}

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    ivec2 hi = textureSize(t_depth, 0) - 1;
#if PASS == 0
    vec2 w[2 * WIN_R + 1];
    for (int m = -WIN_R; m <= WIN_R; ++m)
        w[m + WIN_R] = vec2(depth_at(p + ivec2(m, 0), hi));
    o_x = tent_sobel_x(w, p.x, hi.x);
#else
    vec2 w[2 * TENT_R + 1];
    for (int j = -TENT_R; j <= TENT_R; ++j)
        w[j + TENT_R] = vec2(depth_at(p + ivec2(j, 0), hi));
    o_x = tent_of(w);
#endif
}
#elif PASS == 1 || PASS == 5
uniform sampler2D t_x;  // PASS 1: the x pass; PASS 5: its y tents
uniform float u_threshold;
uniform float u_scale;
#ifdef LOC_EDGES
layout(location = LOC_EDGES) out float o_edges;
#endif
#ifdef LOC_GRADIENT
layout(location = LOC_GRADIENT) out vec2 o_gradient;
#endif
#ifdef LOC_MAGNITUDE
layout(location = LOC_MAGNITUDE) out float o_magnitude;
#endif

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
#if PASS == 1
    ivec2 hi = textureSize(t_x, 0) - 1;
    vec2 w[2 * WIN_R + 1];
    for (int m = -WIN_R; m <= WIN_R; ++m)
        w[m + WIN_R] = texelFetch(t_x, ivec2(p.x, clamp(p.y + m, 0, hi.y)), 0).xy;
    vec2 g = tent_sobel_y(w, p.y, hi.y) * (u_scale / u_tent_norm);
#else
    vec2 g = sobel_y_from(t_x, p) * (u_scale / u_tent_norm);
#endif
    float mag = sqrt(g.x * g.x + g.y * g.y);
#ifdef LOC_EDGES
    o_edges = mag >= u_threshold ? 1.0 : 0.0;
#endif
#ifdef LOC_GRADIENT
    o_gradient = g;
#endif
#ifdef LOC_MAGNITUDE
    o_magnitude = mag;
#endif
}
#endif
#endif
