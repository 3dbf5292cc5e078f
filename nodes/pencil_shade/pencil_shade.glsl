#version 330
// Geometry pass of the interior shading (Lee et al. 2006, §4.2.2): a small G-buffer that hatch.glsl shades
// in one full-screen pass, so every pixel runs the tonal-art-map lookups once (on llvmpipe a fragment of a
// triangle a few pixels wide costs as much as a whole 2x2 or 4x4 block of them).
// Vertex stage: each vertex's minimum-curvature direction is projected to the screen (exact derivative of
// the projection); where it is unreliable (a fixed-frame fallback of the curvature node, or foreshortened
// towards the viewer) it is blended, as a line (doubled angle), towards a fixed screen-space direction.
// Every vertex has a slot (0, 1, 2; the three corners of a triangle have different ones, vertices are copied
// where their triangles need it): it puts its one-hot barycentric coordinate and its direction's angle in
// its slot, so after interpolation angle_i = (b_i angle_i) / b_i gives every fragment the angles of all
// three corners of its triangle (what a geometry shader handed on as flat values).
// Fragment stage: the three angles, darkness from the light, two blending weights (the third is 1 - both),
// each as 16 bits, and the object's index, in one RGBA32UI texel (one target: two cost a quarter more here).
// SURFACE (anchor: surface): two more targets hold each corner's hatching coordinates on the surface, in tonal-art-
// map tiles: (dot(P, d_i), dot(P, e_i)) with P the rest-pose object-space point (relative to the rest pose's
// box centre, times tiles per object unit), d_i corner i's rest-pose minimum-curvature direction and e_i = n_i x
// d_i; the corners' directions reach the fragment by the same one-hot slots as the angles. With them the level
// of detail, from the coordinates' screen derivatives within the triangle.
#if defined VERTEX_SHADER
in vec3 in_pos;
in vec3 in_normal;
in vec3 in_dir;       // object-space minimum-curvature direction (a line: sign arbitrary)
in float in_trust;    // 1: a measured or smoothed direction, 0: the curvature node's fixed-frame fallback
in float in_corner;   // the vertex's slot, 0, 1 or 2: different at the three corners of every triangle
uniform mat4 u_mvp;            // u_proj u_view u_model, multiplied once on the CPU (not per vertex)
uniform mat3 u_model3;         // the model matrix's linear part
uniform float u_proj_y;        // u_proj[1][1]
uniform mat3 u_normal_view;
uniform vec2 u_viewport;       // pixels
uniform vec2 u_fallback_dir;   // unit screen direction used where the curvature direction is unreliable
uniform vec2 u_foreshortening; // projected/true length ratio: below .x the fallback, above .y the direction
// two vec4s rather than a vec3, a vec2 and a vec3: a few per cent less of the draw on llvmpipe
out vec4 v_normal_b0;  // view-space normal; one-hot slot 0 (the barycentric coordinate once interpolated)
out vec4 v_angles_b1;  // one-hot x this corner's screen angle; one-hot slot 1 (slot 2 is 1 - both)
#ifdef LIGHTS
uniform mat4 u_model_view;     // u_view u_model: the view-space position the punctual lights need
out vec3 v_view_pos;
#endif
#ifdef SURFACE
in vec3 in_rest;     // rest-pose object-space position relative to the rest pose's box centre
in vec3 in_rdir;     // rest-pose minimum-curvature direction, unit, in the tangent plane (0: none)
in vec3 in_rperp;    // rest-pose normal x in_rdir
uniform float u_tiles;         // tonal-art-map tiles per object unit
out vec3 v_rest;               // in_rest x u_tiles
out vec3 v_sdir[3];            // one-hot slot x in_rdir
out vec3 v_sperp[3];           // one-hot slot x in_rperp
#endif

vec2 doubled(vec2 d) { return vec2(d.x * d.x - d.y * d.y, 2.0 * d.x * d.y); }

void main() {
    vec4 clip = u_mvp * vec4(in_pos, 1.0);
    vec4 dclip = u_mvp * vec4(in_dir, 0.0);
    // d(ndc.xy) along the direction, in pixels per unit of in_dir
    vec2 d2 = (dclip.xy * clip.w - clip.xy * dclip.w) / (clip.w * clip.w) * 0.5 * u_viewport;
    float full = u_proj_y * 0.5 * u_viewport.y / max(clip.w, 1e-6) * length(u_model3 * in_dir);
    float ratio = length(d2) / max(full, 1e-12);
    float trust = in_trust * smoothstep(u_foreshortening.x, u_foreshortening.y, ratio);
    vec2 d = length(d2) > 0.0 ? normalize(d2) : u_fallback_dir;
    vec2 m = mix(doubled(u_fallback_dir), doubled(d), trust);
    if (dot(m, m) < 1e-8) m = doubled(u_fallback_dir);
    float angle = 0.5 * atan(m.y, m.x);  // the line's angle in (-90, 90] degrees
    vec3 onehot = vec3(equal(vec3(in_corner), vec3(0.0, 1.0, 2.0)));
    v_normal_b0 = vec4(u_normal_view * in_normal, onehot.x);
    v_angles_b1 = vec4(onehot * angle, onehot.y);
#ifdef LIGHTS
    v_view_pos = (u_model_view * vec4(in_pos, 1.0)).xyz;
#endif
#ifdef SURFACE
    v_rest = in_rest * u_tiles;
    for (int i = 0; i < 3; ++i) {
        v_sdir[i] = onehot[i] * in_rdir;
        v_sperp[i] = onehot[i] * in_rperp;
    }
#endif
    gl_Position = clip;
}

#elif defined FRAGMENT_SHADER
in vec4 v_normal_b0;
in vec4 v_angles_b1;
uniform vec3 u_light;          // view-space unit direction towards the light
uniform float u_light_intensity;
#ifdef LIGHTS
// the scene's punctual lights replace u_light: the luminance of their irradiance (nodegraph/scene/lights.py)
#include "lights.glsl"
in vec3 v_view_pos;
#endif
uniform vec2 u_viewport;       // pixels
uniform vec2 u_tan_half;       // tangents of half the field of view (x, y): the view ray through a pixel
uniform vec2 u_grazing;        // brightness a surface keeps seen edge-on; N.V where that lift has faded to 0
uniform uint u_object;         // the object's index: hatch.glsl looks its anchor up
#if FACE_ORDER
uniform sampler2D t_slots;     // per triangle (gl_PrimitiveID, SLOT_ROWS per row): slot(0) + 3 slot(1), / 255
#endif
layout(location = 0) out uvec4 o_gbuffer;  // angles 0 | 1, angle 2 | darkness, weights 0 | 1, object (16 | 16 bits)
#ifdef SURFACE
in vec3 v_rest;
in vec3 v_sdir[3];
in vec3 v_sperp[3];
uniform float u_tam_size;      // texels per tile
layout(location = 1) out vec4 o_surface0;  // corner 0's and corner 1's surface coordinates (tiles)
layout(location = 2) out vec4 o_surface1;  // corner 2's; level of detail; 0
#endif

float corner_angle(float a, float b) { return b > 0.0 ? a / b : 0.0; }  // b = 0: the weight is 0 too

// two values in [0, 1] as 16-bit fixed point (steps of 1.5e-5): x in the low half, y in the high one
uint pack2(float x, float y) {
    uvec2 q = uvec2(clamp(vec2(x, y), 0.0, 1.0) * 65535.0 + 0.5);
    return q.x | (q.y << 16);
}
const float HALF_PI = 1.5707963267948966;

void main() {
    vec3 n = normalize(v_normal_b0.xyz);
    if (!gl_FrontFacing) n = -n;
    // tone: brightness from the light; the darkest tone index is scaled by 1 - sqrt(brightness). A surface seen
    // nearly edge-on keeps some: lifted towards u_grazing.x as N.V falls from u_grazing.y to 0 (reference.py)
    vec3 to_eye = normalize(vec3((1.0 - 2.0 * gl_FragCoord.xy / u_viewport) * u_tan_half, 1.0));
    float facing = max(dot(n, to_eye), 0.0);
#ifdef LIGHTS
    float lit = light_brightness(v_view_pos, n);
#else
    float lit = max(dot(n, u_light), 0.0);
#endif
    float brightness = max(lit,
                           u_grazing.x * clamp(1.0 - facing / max(u_grazing.y, 1e-6), 0.0, 1.0));
    float darkness = 1.0 - sqrt(clamp(brightness * u_light_intensity, 0.0, 1.0));
    vec3 w = vec3(v_normal_b0.w, v_angles_b1.w, 1.0 - v_normal_b0.w - v_angles_b1.w);
    vec3 wa = v_angles_b1.xyz;
    vec3 a = vec3(corner_angle(wa.x, w.x), corner_angle(wa.y, w.y), corner_angle(wa.z, w.z));
#if FACE_ORDER
    // weights and angles in the order of the triangle's corners (the `blend` output), not of the slots
    float code = floor(texelFetch(t_slots, ivec2(gl_PrimitiveID % SLOT_ROW, gl_PrimitiveID / SLOT_ROW), 0).r
                       * 255.0 + 0.5);
    float s1 = floor(code / 3.0);
    mat3 pick = mat3(vec3(equal(vec3(code - 3.0 * s1), vec3(0.0, 1.0, 2.0))),
                     vec3(equal(vec3(s1), vec3(0.0, 1.0, 2.0))),
                     vec3(equal(vec3(3.0 - code + 2.0 * s1), vec3(0.0, 1.0, 2.0))));  // column j: corner j's slot
    w = w * pick;
    a = a * pick;
#endif
#ifdef SURFACE
    // slot i's direction is (b_i d_i) / b_i; where b_i is 0 its weight is 0 too
    vec3 su = vec3(0.0), sv = vec3(0.0);
    for (int i = 0; i < 3; ++i) {
        float b = i == 0 ? v_normal_b0.w : (i == 1 ? v_angles_b1.w : 1.0 - v_normal_b0.w - v_angles_b1.w);
        if (b > 0.0) {
            su[i] = dot(v_rest, v_sdir[i]) / b;
            sv[i] = dot(v_rest, v_sperp[i]) / b;
        }
    }
#if FACE_ORDER
    su = su * pick;
    sv = sv * pick;
#endif
    // texels per pixel: the rest position's screen derivative (the coordinates' gradient is at most that long)
    float rho = max(length(dFdx(v_rest)), length(dFdy(v_rest))) * u_tam_size;
    o_surface0 = vec4(su.x, sv.x, su.y, sv.y);
    o_surface1 = vec4(su.z, sv.z, log2(max(rho, 1.0)), 0.0);
#endif
    vec3 an = a / (2.0 * HALF_PI) + 0.5;  // (-90, 90] degrees -> (0, 1]
    o_gbuffer = uvec4(pack2(an.x, an.y), pack2(an.z, darkness), pack2(w.x, w.y), u_object);
}
#endif
