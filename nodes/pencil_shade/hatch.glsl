#version 330
// Full-screen passes of the interior shading (Lee et al. 2006, §4.2.2) over the G-buffer of pencil_shade.glsl:
// first the background pass (BACKGROUND, no depth test) draws bare paper over the whole image; then the
// object pass, depth-tested against the geometry pass's depth buffer (depth test ">", the triangle at the
// far plane: covered pixels only) and scissored to the objects' boxes, draws over it the hatching layers
// lighter first, each the barycentric blend of the tonal art map sampled in the three corners' rotated
// frames (3-way blending), graphite modulated by paper grain, layers multiplied so that crossings darken.
// For `color` both then multiply the contours in and lay graphite over paper whose relief shows faintly.
// SURFACE (anchor: surface): the frames' texture coordinates are the surface coordinates of pencil_shade.glsl
// (fixed to the rest-pose surface), each layer's turn a rotation of them, at their own level of detail.
// llvmpipe runs both sides of every branch, but skips a block of pixels that fails the depth test before
// shading it: the split is what keeps the background from paying for the lookups.
#if defined VERTEX_SHADER
out vec2 v_uv;
void main() {
    vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);
    v_uv = p;
    gl_Position = vec4(p * 2.0 - 1.0, 1.0, 1.0);  // window depth 1: behind every object, level with the clear
}

#elif defined FRAGMENT_SHADER
in vec2 v_uv;
uniform usampler2D t_gbuffer;  // pencil_shade.glsl's: angles, darkness, weights 0 and 1, object index
uniform sampler2D t_anchors;   // per object (x = index): the pixel its hatching frame is centred on
#if defined SURFACE && !BACKGROUND
uniform sampler2D t_surface0;  // corner 0's and 1's surface coordinates (tiles)
uniform sampler2D t_surface1;  // corner 2's; level of detail
#endif
uniform sampler2DArray t_tam;  // tones, layer 0 lightest, wrap-around
#if PAPER
uniform sampler2D t_paper;     // grain normal (xyz), height (w)
#endif
#if ALBEDO
uniform sampler2D t_albedo;      // the surface colour (rasterize.color, display values)
uniform float u_albedo_ref;      // CIE lightness L* that hatches as N.L alone: the default mesh colour's
uniform float u_albedo_weight;   // brightness x (L* / u_albedo_ref) ^ u_albedo_weight
#include "albedo.glsl"
#endif
#if CONTOUR
uniform sampler2D t_contour;   // contours, 1 = paper
#endif
uniform float u_max_tone;      // darkest tone index a layer reaches
uniform float u_layer_offset;  // darkness at which each further layer starts, per layer
uniform vec2 u_layer_rot[LAYERS];    // (cos, sin) of each layer's rotation from the blended frame
uniform vec2 u_layer_shift[LAYERS];  // texture-space shift per layer (decorrelates their strokes)
uniform float u_texel_scale;   // TAM texels per pixel
uniform float u_lod;
uniform float u_grain;
uniform vec3 u_paper_color;
uniform vec3 u_graphite_color;
uniform float u_paper_tint;
#ifdef LOC_SHADE
layout(location = LOC_SHADE) out float o_shade;
#endif
#ifdef LOC_BLEND
layout(location = LOC_BLEND) out vec4 o_blend;
#endif
#ifdef LOC_COLOR
layout(location = LOC_COLOR) out vec4 o_color;
#endif

float tam(vec2 uv, float t) {
    float t0 = floor(t);
    float a = textureLod(t_tam, vec3(uv, t0), u_lod).r;
    float b = textureLod(t_tam, vec3(uv, min(t0 + 1.0, float(textureSize(t_tam, 0).z - 1))), u_lod).r;
    return mix(a, b, t - t0);
}

float tam_lod(vec2 uv, float t, float lod) {
    float t0 = floor(t);
    float a = textureLod(t_tam, vec3(uv, t0), lod).r;
    float b = textureLod(t_tam, vec3(uv, min(t0 + 1.0, float(textureSize(t_tam, 0).z - 1))), lod).r;
    return mix(a, b, t - t0);
}

vec2 unpack2(uint v) { return vec2(uvec2(v & 0xFFFFu, v >> 16)) / 65535.0; }

const float PI = 3.141592653589793;

vec2 rot(vec2 d, vec2 cs) { return vec2(cs.x * d.x - cs.y * d.y, cs.y * d.x + cs.x * d.y); }

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
#if PAPER
    ivec2 tile = ivec2(mod(gl_FragCoord.xy, vec2(textureSize(t_paper, 0))));  // float mod: integer % is slow on llvmpipe
    vec4 grain = texelFetch(t_paper, tile, 0);
#endif
#if BACKGROUND
    float value = 1.0;
#else
    uvec4 g = texelFetch(t_gbuffer, px, 0);
    vec2 a01 = unpack2(g.x), a2d = unpack2(g.y), w01 = unpack2(g.z);
    vec3 angle = (vec3(a01, a2d.x) - 0.5) * PI;
    float darkness = a2d.y;
#if ALBEDO
    // tone from the lit albedo: brightness (1 - darkness)^2 scaled by the albedo's lightness (CIE L*, the value
    // an artist judges) against the reference's, so darker materials hatch darker (albedo.glsl)
    darkness = 1.0 - min((1.0 - darkness)
                         * sqrt(albedo_factor(texture(t_albedo, v_uv).rgb, u_albedo_ref, u_albedo_weight)), 1.0);
#endif
    vec3 w = vec3(w01, 1.0 - w01.x - w01.y);
    vec2 dir0 = vec2(cos(angle.x), sin(angle.x));
    vec2 dir1 = vec2(cos(angle.y), sin(angle.y));
    vec2 dir2 = vec2(cos(angle.z), sin(angle.z));
#ifdef SURFACE
    vec4 s0 = texelFetch(t_surface0, px, 0);
    vec4 s1 = texelFetch(t_surface1, px, 0);
#else
    vec2 anchor = texelFetch(t_anchors, ivec2(int(g.w), 0), 0).xy;
    vec2 tam_size = vec2(textureSize(t_tam, 0).xy);
    vec2 p = (gl_FragCoord.xy - anchor) * u_texel_scale / tam_size;
#endif
    vec2 strongest = w.x >= w.y ? (w.x >= w.z ? dir0 : dir2) : (w.y >= w.z ? dir1 : dir2);
    float value = 1.0;
    for (int k = 0; k < LAYERS; ++k) {
        float start = float(k) * u_layer_offset;
        float share = clamp((darkness - start) / max(1.0 - start, 1e-6), 0.0, 1.0);
        if (share <= 0.0) break;  // lighter layers first: a later layer only where it is darker still
        float t = share * u_max_tone;
        vec2 cs = u_layer_rot[k];
        vec2 sh = u_layer_shift[k];
#ifdef SURFACE
        // turned by the layer's angle in the tangent plane: d' = c d + s e, e' = c e - s d
        vec2 r = vec2(cs.x, -cs.y);
        float layer = w.x * tam_lod(rot(s0.xy, r) + sh, t, s1.z)
                    + w.y * tam_lod(rot(s0.zw, r) + sh, t, s1.z)
                    + w.z * tam_lod(rot(s1.xy, r) + sh, t, s1.z);
#else
        vec2 d0 = rot(dir0, cs), d1 = rot(dir1, cs), d2 = rot(dir2, cs);
        float layer = w.x * tam(vec2(dot(p, d0), dot(p, vec2(-d0.y, d0.x))) + sh, t)
                    + w.y * tam(vec2(dot(p, d1), dot(p, vec2(-d1.y, d1.x))) + sh, t)
                    + w.z * tam(vec2(dot(p, d2), dot(p, vec2(-d2.y, d2.x))) + sh, t);
#endif
        float dark = 1.0 - layer;
#if PAPER
        // graphite catches on the side of the paper tooth the stroke runs into (mean factor 1)
        dark *= clamp(1.0 + u_grain * 2.5 * dot(grain.xy, rot(strongest, cs)), 0.0, 2.0);
#endif
        value *= 1.0 - clamp(dark, 0.0, 1.0);
    }
#endif
#ifdef LOC_SHADE
    o_shade = value;
#endif
#ifdef LOC_BLEND
#if BACKGROUND
    o_blend = vec4(0.0, 0.0, 0.0, -1.0);
#else
    o_blend = vec4(w, darkness * u_max_tone);
#endif
#endif
#ifdef LOC_COLOR
#if CONTOUR
#if CONTOUR_SAME_SIZE
    value *= texelFetch(t_contour, px, 0).r;
#else
    value *= texture(t_contour, v_uv).r;
#endif
#endif
    vec3 paper = u_paper_color;
#if PAPER
    paper *= 1.0 - u_paper_tint * (1.0 - grain.w);
#endif
    o_color = vec4(mix(u_graphite_color, paper, clamp(value, 0.0, 1.0)), 1.0);
#endif
}
#endif
