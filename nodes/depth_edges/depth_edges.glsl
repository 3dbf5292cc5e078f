#version 330
// Curtis' edge map (seed 004): 3x3 tent blur of the depth map, Sobel gradient, magnitude, threshold.
// PASS 0: depth in [0, 1] (1 = background; DEPTH_MODE 1 converts linear view depth, 0 = background,
//         with the near and far planes) blurred by [1 2 1; 2 4 2; 1 2 1] / 16, edge-clamped.
// PASS 1: (gx, gy) = the seed's Sobel pair of the blurred depth times u_scale (height / reference height:
//         per pixel of an image of the reference height), mag = |(gx, gy)|, edge = mag >= threshold.
#if defined FRAGMENT_SHADER
#if PASS == 0
uniform sampler2D t_depth;
uniform vec2 u_range;  // linear depth mapped to 0 and 1
layout(location = 0) out float o_blur;

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
    float sum = 0.0;
    for (int j = -1; j <= 1; ++j)
        for (int i = -1; i <= 1; ++i)
            sum += float((2 - abs(i)) * (2 - abs(j))) * depth_at(p + ivec2(i, j), hi);
    o_blur = sum / 16.0;
}
#else
#include "seed_sobel.glsl"
uniform sampler2D t_blur;
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
    vec2 g = seed_sobel(t_blur, ivec2(gl_FragCoord.xy)) * u_scale;
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
