#version 330
// G-buffer pass (Nienhaus & Döllner §3.1, §4.2). Each enabled output is a define giving its
// colour-attachment location, so a pass writes only the buffers the plan needs.
#ifdef SURFACE
#include "surface.glsl"
#endif
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
#ifdef LIGHTS
uniform mat4 u_model_view;   // u_view u_model: view-space position, for the punctual lights
out vec3 v_view_pos;
#endif
out float v_view_depth;
void main() {
#ifdef SURFACE
    surface_pass();
#endif
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
#ifdef LIGHTS
    v_view_pos = (u_model_view * q).xyz;
#endif
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
#ifdef LIGHTS
// the scene's punctual lights replace u_light: irradiance times exposure (nodegraph/scene/lights.py)
#include "lights.glsl"
in vec3 v_view_pos;
#ifdef BANDS
uniform vec2 u_thresholds;   // tone_bands on the lights' brightness (tone_bands.glsl does it for u_light)
uniform vec3 u_factors;
#endif
#endif
uniform float u_object_id;
uniform float u_ambient;
#ifdef SURFACE
vec3 display(vec3 c) {       // linear -> sRGB-encoded display values, what u_color holds
    c = clamp(c, 0.0, 1.0);
    return mix(12.92 * c, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), c));
}

// factor x vertex colour x texture, in linear values, as display values; a MASK cut-out discards the fragment
vec3 surface_albedo() {
    vec4 c = surface_base();
#if MASK
    if (c.a < u_cutoff) discard;
#endif
    return display(c.rgb);
}
#endif
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
#ifdef SURFACE
    vec3 albedo = surface_albedo();
#else
    vec3 albedo = u_color;
#endif
#ifdef LOC_COLOR
#if LIT && defined(LIGHTS)
    vec3 diffuse = min(light_irradiance(v_view_pos, n), vec3(1.0));
    o_color = vec4(albedo * (u_ambient + (1.0 - u_ambient) * diffuse), 1.0);
#elif LIT
    float diffuse = max(dot(n, u_light), 0.0);
    o_color = vec4(albedo * (u_ambient + (1.0 - u_ambient) * diffuse), 1.0);
#elif defined(LIGHTS) && defined(BANDS)
    float d = light_brightness(v_view_pos, n);
    o_color = vec4(albedo * (d < u_thresholds.x ? u_factors.x : (d < u_thresholds.y ? u_factors.y : u_factors.z)),
                   1.0);
#else
    o_color = vec4(albedo, 1.0);
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
