#version 330
// Multiple contour drawing (Lee et al. 2006, §4.2.1): the edge map is read through each distortion
// layer (one shaken attempt at the contour per layer), every attempt deposits graphite with its own
// pressure, darker where the surface faces away from the light, grainy where the paper tooth meets the
// stroke, and attempts multiply (value = prod(1 - darkness_k)), so where they overlap the line darkens.
#if defined FRAGMENT_SHADER
uniform sampler2D t_edges;            // edge intensity, 1 = edge (bilinear, clamped)
uniform sampler2DArray t_distortion;  // per-layer offsets in pixels (x, y)
uniform sampler2D t_normal_depth;     // view-space normal (xyz), linear depth (w, 0 = background)
#if PAPER
uniform sampler2D t_paper;            // grain normal (xyz) and height (w), tiled at one texel per pixel
#endif
uniform vec3 u_light;                 // view-space unit direction towards the light
uniform float u_tone;                 // darkness of one full-pressure attempt over an edge
uniform float u_light_weight;         // how much the light lightens the line
uniform float u_grain;                // paper grain strength
uniform float u_pressure[LAYERS];     // per-attempt pressure in (0, 1]
uniform vec3 u_paper_color;           // paper colour
uniform vec3 u_graphite_color;        // graphite colour
uniform float u_paper_tint;           // visibility of the paper relief on bare paper
#if ALBEDO
uniform sampler2D t_albedo;           // the surface colour (rasterize.color, display values), as normal_depth
uniform float u_albedo_ref;           // L* whose lines are as without albedo: the default mesh colour's
uniform float u_albedo_weight;        // light brightness x (L* / u_albedo_ref) ^ u_albedo_weight
#include "albedo.glsl"
#endif
#ifdef LIGHTS
// the scene's punctual lights replace u_light (nodegraph/scene/lights.py): the line's light term is
// sqrt(brightness) at the view-space point under the pixel, rebuilt from its linear depth
#include "lights.glsl"
uniform mat4 u_inv_proj;              // clip -> view space, the camera's at the normal_depth buffer's aspect
vec3 view_point(ivec2 q, float depth) {
    vec2 ndc = (vec2(q) + 0.5) / vec2(textureSize(t_normal_depth, 0)) * 2.0 - 1.0;
    vec4 a = u_inv_proj * vec4(ndc, -1.0, 1.0);
    vec4 b = u_inv_proj * vec4(ndc, 1.0, 1.0);
    a.xyz /= a.w;
    b.xyz /= b.w;
    return mix(a.xyz, b.xyz, (depth + a.z) / (a.z - b.z));  // the point of the pixel's ray at -z = depth
}
#endif
#ifdef LOC_OUT
layout(location = LOC_OUT) out float o_out;
#endif
#ifdef LOC_COLOR
layout(location = LOC_COLOR) out vec4 o_color;
#endif

#if OUTSIDE
// Where every attempt reads no edge (outside the edges' footprint grown by the largest shift) each attempt's
// factor is exactly 1, so the value is 1 and only the paper is computed. u_outside is that 1, a uniform, so
// the colour below is the same arithmetic on the same numbers as the full pass gives there.
uniform float u_outside;
#endif

void main() {
#if OUTSIDE
#if PAPER
    vec4 grain = texelFetch(t_paper, ivec2(mod(gl_FragCoord.xy, vec2(textureSize(t_paper, 0)))), 0);
#endif
    float value = u_outside;
#else
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec2 size = vec2(textureSize(t_edges, 0));
    ivec2 maxpx = textureSize(t_normal_depth, 0) - 1;
#if PAPER
    // float mod: integer % is scalarised on llvmpipe
    vec4 grain = texelFetch(t_paper, ivec2(mod(gl_FragCoord.xy, vec2(textureSize(t_paper, 0)))), 0);
#endif
    // The light and the stroke direction come from the surface under the pixel (the report's choice);
    // where the pixel is off the surface (an attempt shaken past the silhouette) from the surface under
    // the first attempt's edge sample. Once per pixel: llvmpipe runs both sides of every branch.
    vec2 p0 = gl_FragCoord.xy + texelFetch(t_distortion, ivec3(px, 0), 0).xy;
    vec4 nd = texelFetch(t_normal_depth, px, 0);
    vec4 there = texelFetch(t_normal_depth, clamp(ivec2(floor(p0)), ivec2(0), maxpx), 0);
#if defined(LIGHTS) || ALBEDO
    ivec2 q = nd.w > 0.0 ? px : clamp(ivec2(floor(p0)), ivec2(0), maxpx);
#endif
    nd = nd.w > 0.0 ? nd : there;
#ifdef LIGHTS
    float light = nd.w > 0.0 ? sqrt(clamp(light_brightness(view_point(q, nd.w), normalize(nd.xyz)), 0.0, 1.0))
                             : sqrt(0.5);
#else
    // light contribution sqrt((N.L) * 0.5 + 0.5) (the report's); background reads as half lit
    float light = nd.w > 0.0 ? sqrt(clamp(dot(normalize(nd.xyz), u_light) * 0.5 + 0.5, 0.0, 1.0)) : sqrt(0.5);
#endif
#if ALBEDO
    // a darker material: less light, a darker line (brightness x (L* / ref)^weight; the light is its sqrt)
    if (nd.w > 0.0)
        light = min(light * sqrt(albedo_factor(texelFetch(t_albedo, q, 0).rgb, u_albedo_ref, u_albedo_weight)), 1.0);
#endif
    float stroke = u_tone * (1.0 - u_light_weight * light);
#if PAPER
    // a contour runs across the projected normal; graphite catches on the side of the paper tooth the
    // stroke runs into (mean factor 1; the line's sign only mirrors the pattern)
    vec2 dir = length(nd.xy) > 1e-4 ? normalize(vec2(-nd.y, nd.x)) : vec2(1.0, 0.0);
    stroke *= clamp(1.0 + u_grain * 2.5 * dot(grain.xy, dir), 0.0, 2.0);
#endif
    float value = 1.0;
    for (int k = 0; k < LAYERS; ++k) {
        vec2 p = k == 0 ? p0 : gl_FragCoord.xy + texelFetch(t_distortion, ivec3(px, k), 0).xy;
        float e = clamp(texture(t_edges, p / size).r, 0.0, 1.0);
        // no edge, no graphite: exactly 1 whatever the stroke (even one made NaN by a degenerate normal)
        value *= e > 0.0 ? 1.0 - clamp(stroke * u_pressure[k] * e, 0.0, 1.0) : 1.0;
    }
#endif
#ifdef LOC_OUT
    o_out = value;
#endif
#ifdef LOC_COLOR
    vec3 paper = u_paper_color;
#if PAPER
    paper *= 1.0 - u_paper_tint * (1.0 - grain.w);  // valleys of the tooth read slightly darker
#endif
    o_color = vec4(mix(u_graphite_color, paper, value), 1.0);
#endif
}
#endif
