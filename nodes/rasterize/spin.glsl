#version 330
// `spin` (docs/animation.md, Making films): how far the surface under each pixel has turned in the picture's
// plane since frame 0, as (cos, sin). The geometry is drawn as the G-buffer pass draws it (same positions,
// enlargement and culling, own depth buffer). The turn of a surface point is the linear map that carries
// object-space directions to view space now, times its inverse at frame 0: u_now K u_then, where K is the identity
// for a rigid object and, for a skinned vertex, its skin's linear part now times its inverse at frame 0 (in_k*,
// PER_VERTEX). The angle is that of the rotation nearest the map's upper-left 2 x 2 block (the picture's plane):
// atan2(m10 - m01, m00 + m11). A turn about an axis in the picture's plane leaves it at 0. A glTF cut-out (SURFACE,
// MASK) is cut as the G-buffer pass cuts it.
#ifdef SURFACE
#include "surface.glsl"
#endif
#if defined VERTEX_SHADER
in vec3 in_pos;
in vec3 in_smooth;
#ifdef PER_VERTEX
in vec3 in_k0;  // K's columns
in vec3 in_k1;
in vec3 in_k2;
#endif
uniform mat4 u_mvp;
uniform float u_enlarge;  // object-space distance along in_smooth
uniform mat3 u_now;       // object -> view now (linear part)
uniform mat3 u_then;      // view -> object at frame 0 (linear part)
out vec2 v_spin;
void main() {
#ifdef SURFACE
    surface_pass();
#endif
    gl_Position = u_mvp * vec4(in_pos + in_smooth * u_enlarge, 1.0);
#ifdef PER_VERTEX
    mat3 m = u_now * mat3(in_k0, in_k1, in_k2) * u_then;
#else
    mat3 m = u_now * u_then;
#endif
    // GLSL matrices are column-major: m[c][r]
    v_spin = vec2(m[0][0] + m[1][1], m[0][1] - m[1][0]);
}
#elif defined FRAGMENT_SHADER
in vec2 v_spin;
out vec2 o_spin;
void main() {
#ifdef SURFACE
#if MASK
    if (surface_base().a < u_cutoff) discard;
#endif
#endif
    float n = length(v_spin);
    o_spin = n > 1e-12 ? v_spin / n : vec2(1.0, 0.0);
}
#endif
