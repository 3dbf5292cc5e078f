#version 330
// Screen-space motion (docs/animation.md, Making films): the geometry is drawn as the G-buffer pass draws it
// (same positions, enlargement and culling, own depth buffer), and each fragment writes where the same surface
// point was in the previous frame: its window position in pixels (gl_FragCoord convention) and window depth,
// from the previous frame's camera, object transform and posed vertices. A glTF surface with alphaMode MASK
// (SURFACE, MASK) is cut as the G-buffer pass cuts it: alpha = factor x vertex colour x texture below the cutoff
// discards the fragment, so a cut-out leaf shows the motion of what lies behind it.
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
#ifdef SURFACE
in vec2 in_uv;
in vec4 in_vcolor;
uniform vec3 u_uv_row0;        // KHR_texture_transform's first two rows
uniform vec3 u_uv_row1;
out vec2 v_uv;
out float v_alpha;
#endif
void main() {
#ifdef SURFACE
    v_uv = vec2(dot(u_uv_row0, vec3(in_uv, 1.0)), dot(u_uv_row1, vec3(in_uv, 1.0)));
    v_alpha = in_vcolor.a;
#endif
    vec3 p = in_pos + in_smooth * u_enlarge;
    v_prev_clip = u_prev_mvp * vec4(in_prev + in_prev_smooth * u_prev_enlarge, 1.0);
    gl_Position = u_mvp * vec4(p, 1.0);
}
#elif defined FRAGMENT_SHADER
in vec4 v_prev_clip;
uniform vec2 u_size;           // the image in pixels
out vec4 o_motion;
#ifdef SURFACE
in vec2 v_uv;
in float v_alpha;
uniform vec4 u_factor;         // baseColorFactor (its alpha)
uniform sampler2D t_base;
uniform vec2 u_mirror;         // 1 where the sampler's wrap mode is MIRRORED_REPEAT (s, t)
uniform float u_cutoff;        // alphaCutoff
#endif
void main() {
#ifdef SURFACE
#if MASK
    float a = u_factor.a;
#if VCOLOR
    a *= v_alpha;
#endif
#if TEXTURE
    vec2 uv = mix(v_uv, 1.0 - abs(mod(v_uv, 2.0) - 1.0), u_mirror);
    a *= textureGrad(t_base, uv, dFdx(v_uv), dFdy(v_uv)).a;
#endif
    if (a < u_cutoff) discard;
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
