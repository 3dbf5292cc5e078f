#version 330
// Geometry-controlled uncertainty (Nienhaus & Döllner §4.1–4.3): p(.) reads the object-space position
// g(s,t) that rasterize wrote (enlarged geometry, alpha = coverage) and evaluates 3D Perlin
// turbulence/fbm there, two decorrelated channels (off_s, off_t). The noise is evaluated, not read from
// a baked 3D texture: the same function as nodes/perlin_noise/reference.py noise3_at, exact to ~1e-6.
#include "../perlin_noise/improved_noise.glsl"
#if defined FRAGMENT_SHADER
uniform sampler2D t_position;
uniform float u_scale;        // noise cycles per object-space unit (params.scale / unit length)
uniform ivec3 u_seed_cell;
uniform vec3 u_seed_frac;
uniform int u_octaves;
uniform int u_mode;
uniform vec2 u_background;
layout(location = 0) out vec2 o_out;
void main() {
    vec4 g = texelFetch(t_position, ivec2(gl_FragCoord.xy), 0);
    if (g.a <= 0.0) {
        o_out = u_background;
        return;
    }
    o_out = noise3_at(g.xyz, u_scale, u_seed_cell, u_seed_frac, u_octaves, u_mode);
}
#endif
