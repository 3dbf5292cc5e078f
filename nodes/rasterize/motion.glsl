#version 330
// Screen-space motion (docs/animation.md, Making films): the geometry is drawn as the G-buffer pass draws it
// (same positions, enlargement and culling, own depth buffer), and each fragment writes where the same surface
// point was in the previous frame: its window position in pixels (gl_FragCoord convention) and window depth,
// from the previous frame's camera, object transform and posed vertices. A glTF surface with alphaMode MASK
// (SURFACE, MASK) is cut as the G-buffer pass cuts it: alpha = factor x vertex colour x texture below the cutoff
// discards the fragment, so a cut-out leaf shows the motion of what lies behind it.
#ifdef SURFACE
#include "surface.glsl"
#endif
#if defined VERTEX_SHADER
in vec3 in_pos;
in vec3 in_smooth;
in vec3 in_prev;         // the vertex in the previous frame (object space, relative to the same origin)
in vec3 in_prev_smooth;  // its direction of enlargement in the previous frame
uniform mat4 u_mvp;            // this frame's u_proj u_view u_model
uniform mat4 u_prev_mvp;       // the previous frame's
uniform float u_enlarge;       // object-space distance along in_smooth
uniform float u_prev_enlarge;
out vec4 v_prev_clip;          // clip coordinates are affine in the surface point: interpolated, divided per fragment
void main() {
#ifdef SURFACE
    surface_pass();
#endif
    vec3 p = in_pos + in_smooth * u_enlarge;
    v_prev_clip = u_prev_mvp * vec4(in_prev + in_prev_smooth * u_prev_enlarge, 1.0);
    gl_Position = u_mvp * vec4(p, 1.0);
}
#elif defined FRAGMENT_SHADER
in vec4 v_prev_clip;
uniform vec2 u_size;           // the image in pixels
out vec4 o_motion;
void main() {
#ifdef SURFACE
#if MASK
    if (surface_base().a < u_cutoff) discard;
#endif
#endif
    if (v_prev_clip.w <= 0.0) {  // behind the previous camera: no previous window position
        o_motion = vec4(gl_FragCoord.xy, 2.0, 1.0);
        return;
    }
    vec3 ndc = v_prev_clip.xyz / v_prev_clip.w;
    o_motion = vec4((ndc.xy * 0.5 + 0.5) * u_size, ndc.z * 0.5 + 0.5, 1.0);
}
#endif
