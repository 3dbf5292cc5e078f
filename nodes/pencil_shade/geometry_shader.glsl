#version 330
// The previous implementation of pencil_shade (until version 1), kept as the reference the deferred one is
// measured and compared with (geometry_shader.py). Interior shading with oriented hatching (Lee et al. 2006, §4.2.2).
// Vertex stage: each vertex's minimum-curvature direction is projected to the screen (exact derivative of
// the projection); where it is unreliable (a fixed-frame fallback of the curvature node, or foreshortened
// towards the viewer) it is blended, as a line (doubled angle), towards a fixed screen-space direction.
// Geometry stage: hands every fragment the three (flat) directions of its triangle and its barycentric
// coordinates. Fragment stage: tone index from the light, hatching layers drawn lighter first, each the
// barycentric blend of the tonal art map sampled in the three vertices' rotated frames (3-way blending),
// graphite modulated by paper grain, layers multiplied so that crossings darken.
#if defined VERTEX_SHADER
in vec3 in_pos;
in vec3 in_normal;
in vec3 in_dir;       // object-space minimum-curvature direction (a line: sign arbitrary)
in float in_trust;    // 1: a measured or smoothed direction, 0: the curvature node's fixed-frame fallback
uniform mat4 u_model;
uniform mat4 u_view;
uniform mat4 u_proj;
uniform mat3 u_normal_view;
uniform vec2 u_viewport;       // pixels
uniform vec2 u_fallback_dir;   // unit screen direction used where the curvature direction is unreliable
uniform vec2 u_foreshortening; // projected/true length ratio: below .x the fallback, above .y the direction
out vec3 v_normal;
out vec2 v_dir;

vec2 doubled(vec2 d) { return vec2(d.x * d.x - d.y * d.y, 2.0 * d.x * d.y); }

void main() {
    mat4 mvp = u_proj * u_view * u_model;
    vec4 clip = mvp * vec4(in_pos, 1.0);
    vec4 dclip = mvp * vec4(in_dir, 0.0);
    // d(ndc.xy) along the direction, in pixels per unit of in_dir
    vec2 d2 = (dclip.xy * clip.w - clip.xy * dclip.w) / (clip.w * clip.w) * 0.5 * u_viewport;
    float full = u_proj[1][1] * 0.5 * u_viewport.y / max(clip.w, 1e-6) * length(mat3(u_model) * in_dir);
    float ratio = length(d2) / max(full, 1e-12);
    float trust = in_trust * smoothstep(u_foreshortening.x, u_foreshortening.y, ratio);
    vec2 d = length(d2) > 0.0 ? normalize(d2) : u_fallback_dir;
    vec2 m = mix(doubled(u_fallback_dir), doubled(d), trust);
    if (dot(m, m) < 1e-8) m = doubled(u_fallback_dir);
    float angle = 0.5 * atan(m.y, m.x);
    v_dir = vec2(cos(angle), sin(angle));
    v_normal = u_normal_view * in_normal;
    gl_Position = clip;
}

#elif defined GEOMETRY_SHADER
layout(triangles) in;
layout(triangle_strip, max_vertices = 3) out;
in vec3 v_normal[];
in vec2 v_dir[];
out vec3 f_normal;
out vec3 f_bary;
flat out vec2 f_dir0;
flat out vec2 f_dir1;
flat out vec2 f_dir2;

void main() {
    for (int i = 0; i < 3; ++i) {
        gl_Position = gl_in[i].gl_Position;
        f_normal = v_normal[i];
        f_bary = vec3(i == 0, i == 1, i == 2);
        f_dir0 = v_dir[0];
        f_dir1 = v_dir[1];
        f_dir2 = v_dir[2];
        EmitVertex();
    }
    EndPrimitive();
}

#elif defined FRAGMENT_SHADER
in vec3 f_normal;
in vec3 f_bary;
flat in vec2 f_dir0;
flat in vec2 f_dir1;
flat in vec2 f_dir2;
uniform sampler2DArray t_tam;  // tones, layer 0 lightest, wrap-around
#if PAPER
uniform sampler2D t_paper;     // grain normal (xyz), height (w)
#endif
uniform vec3 u_light;          // view-space unit direction towards the light
uniform float u_light_intensity;
uniform float u_max_tone;      // darkest tone index a layer reaches
uniform float u_layer_offset;  // darkness at which each further layer starts, per layer
uniform vec2 u_layer_rot[LAYERS];    // (cos, sin) of each layer's rotation from the blended frame
uniform vec2 u_layer_shift[LAYERS];  // texture-space shift per layer (decorrelates their strokes)
uniform float u_texel_scale;   // TAM texels per pixel
uniform float u_lod;
uniform vec2 u_anchor;         // pixel the hatching frame is centred on (the object's projected centre)
uniform float u_grain;
#ifdef LOC_SHADE
layout(location = LOC_SHADE) out float o_shade;
#endif
#ifdef LOC_BLEND
layout(location = LOC_BLEND) out vec4 o_blend;
#endif

float tam(vec2 uv, float t) {
    float t0 = floor(t);
    float a = textureLod(t_tam, vec3(uv, t0), u_lod).r;
    float b = textureLod(t_tam, vec3(uv, min(t0 + 1.0, float(textureSize(t_tam, 0).z - 1))), u_lod).r;
    return mix(a, b, t - t0);
}

vec2 rot(vec2 d, vec2 cs) { return vec2(cs.x * d.x - cs.y * d.y, cs.y * d.x + cs.x * d.y); }

void main() {
    vec3 n = normalize(f_normal);
    if (!gl_FrontFacing) n = -n;
    // tone: the darkest tone index scaled by 1 - sqrt(brightness)
    float brightness = max(dot(n, u_light), 0.0);
    float darkness = 1.0 - sqrt(clamp(brightness * u_light_intensity, 0.0, 1.0));
    vec3 w = f_bary / (f_bary.x + f_bary.y + f_bary.z);
    vec2 tam_size = vec2(textureSize(t_tam, 0).xy);
    vec2 p = (gl_FragCoord.xy - u_anchor) * u_texel_scale / tam_size;
    vec2 strongest = w.x >= w.y ? (w.x >= w.z ? f_dir0 : f_dir2) : (w.y >= w.z ? f_dir1 : f_dir2);
#if PAPER
    vec4 grain = texelFetch(t_paper, ivec2(mod(gl_FragCoord.xy, vec2(textureSize(t_paper, 0)))), 0);
#endif
    float value = 1.0;
    for (int k = 0; k < LAYERS; ++k) {
        float start = float(k) * u_layer_offset;
        float share = clamp((darkness - start) / max(1.0 - start, 1e-6), 0.0, 1.0);
        if (share <= 0.0) break;  // lighter layers first: a later layer only where it is darker still
        float t = share * u_max_tone;
        vec2 cs = u_layer_rot[k];
        vec2 sh = u_layer_shift[k];
        vec2 d0 = rot(f_dir0, cs), d1 = rot(f_dir1, cs), d2 = rot(f_dir2, cs);
        float layer = w.x * tam(vec2(dot(p, d0), dot(p, vec2(-d0.y, d0.x))) + sh, t)
                    + w.y * tam(vec2(dot(p, d1), dot(p, vec2(-d1.y, d1.x))) + sh, t)
                    + w.z * tam(vec2(dot(p, d2), dot(p, vec2(-d2.y, d2.x))) + sh, t);
        float dark = 1.0 - layer;
#if PAPER
        // graphite catches on the side of the paper tooth the stroke runs into (mean factor 1)
        dark *= clamp(1.0 + u_grain * 2.5 * dot(grain.xy, rot(strongest, u_layer_rot[k])), 0.0, 2.0);
#endif
        value *= 1.0 - clamp(dark, 0.0, 1.0);
    }
#ifdef LOC_SHADE
    o_shade = value;
#endif
#ifdef LOC_BLEND
    o_blend = vec4(w, darkness * u_max_tone);
#endif
}
#endif
