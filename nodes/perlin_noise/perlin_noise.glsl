#version 330
// Screen-space uncertainty values (paper §3.2): off_s = turbulence(s, t), off_t = turbulence(1-s, 1-t),
// or uncorrelated white noise for roughened profiles (§3.4). Mapping and seeding: reference.py.
#include "improved_noise.glsl"
#if defined FRAGMENT_SHADER
uniform vec2 u_scale_split;
uniform ivec3 u_seed_cell;
uniform vec3 u_seed_frac;
uniform int u_octaves;
uniform int u_mode;
uniform uint u_seed;
uniform uint u_frame;
uniform vec2 u_size;
uniform uvec2 u_cell_ratio;  // white: grain cell of pixel i = i * x / y (reference size / shorter side)
layout(location = 0) out vec2 o_out;
void main() {
#if KIND == 0
    o_out = screen_offset(gl_FragCoord.xy, u_size, u_scale_split, u_seed_cell, u_seed_frac, u_octaves, u_mode);
#else
    o_out = white_offset(uvec2(gl_FragCoord.xy) * u_cell_ratio.x / u_cell_ratio.y, u_seed, u_frame);
#endif
}
#endif
