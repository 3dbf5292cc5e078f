#version 330
// G-buffer pass (Nienhaus & Döllner §3.1, §4.2). Each enabled output is a define giving its
// colour-attachment location, so a pass writes only the buffers the plan needs.
#if defined VERTEX_SHADER
// The matrices are multiplied once on the CPU in float64 (u_view u_model and u_proj u_view u_model), not per
// vertex: on llvmpipe a per-vertex mat4 x mat4 is a measurable share of a dense mesh's draw.
in vec3 in_pos;
in vec3 in_normal;
#if ENLARGE
in vec3 in_smooth;   // welded, smooth vertex normal: the direction of enlargement (§4.2)
uniform float u_enlarge;     // object-space distance along the smooth normal
#endif
uniform mat4 u_mvp;          // u_proj u_view u_model
uniform vec4 u_view_z;       // the third row of u_view u_model: view-space z of a point
uniform mat3 u_normal_view;  // inverse-transpose of (view * model), upper 3x3
out vec3 v_normal;
#ifdef LOC_POSITION
out vec3 v_object;   // only where `position` is written: an unused varying still costs llvmpipe its setup
#endif
out float v_view_depth;
void main() {
#if ENLARGE
    vec3 p = in_pos + in_smooth * u_enlarge;
#else
    vec3 p = in_pos;
#endif
    vec4 q = vec4(p, 1.0);
    v_normal = u_normal_view * in_normal;
#ifdef LOC_POSITION
    v_object = p;
#endif
    v_view_depth = -dot(u_view_z, q);
    gl_Position = u_mvp * q;
}
#elif defined FRAGMENT_SHADER
in vec3 v_normal;
#ifdef LOC_POSITION
in vec3 v_object;
#endif
in float v_view_depth;
uniform vec3 u_color;
uniform vec3 u_light;        // view-space unit direction towards the light
uniform float u_object_id;
uniform float u_ambient;
#ifdef LOC_COLOR
layout(location = LOC_COLOR) out vec4 o_color;
#endif
#ifdef LOC_NORMAL
layout(location = LOC_NORMAL) out vec4 o_normal;
#endif
#ifdef LOC_NORMAL_DEPTH
layout(location = LOC_NORMAL_DEPTH) out vec4 o_normal_depth;
#endif
#ifdef LOC_DEPTH
layout(location = LOC_DEPTH) out float o_depth;
#endif
#ifdef LOC_LINEAR_DEPTH
layout(location = LOC_LINEAR_DEPTH) out float o_linear_depth;
#endif
#ifdef LOC_POSITION
layout(location = LOC_POSITION) out vec4 o_position;
#endif
#ifdef LOC_OBJECT_ID
layout(location = LOC_OBJECT_ID) out float o_object_id;
#endif
void main() {
    vec3 n = normalize(v_normal);
    if (!gl_FrontFacing) n = -n;   // two-sided: open meshes show their inside
#ifdef LOC_COLOR
#if LIT
    float diffuse = max(dot(n, u_light), 0.0);
    o_color = vec4(u_color * (u_ambient + (1.0 - u_ambient) * diffuse), 1.0);
#else
    o_color = vec4(u_color, 1.0);
#endif
#endif
#ifdef LOC_NORMAL
    o_normal = vec4(n, 1.0);
#endif
#ifdef LOC_NORMAL_DEPTH
    o_normal_depth = vec4(n, v_view_depth);
#endif
#ifdef LOC_DEPTH
    o_depth = gl_FragCoord.z;
#endif
#ifdef LOC_LINEAR_DEPTH
    o_linear_depth = v_view_depth;
#endif
#ifdef LOC_POSITION
    o_position = vec4(v_object, 1.0);
#endif
#ifdef LOC_OBJECT_ID
    o_object_id = u_object_id;
#endif
}
#endif
