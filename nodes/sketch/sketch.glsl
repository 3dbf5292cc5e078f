#version 330
// The uncertainty step (Nienhaus & Döllner §3.2): noise offsets, weighted by a 2x2 matrix per map,
// shift the texture coordinates that read the edge map and the shade map; the perturbed edge
// intensity darkens the perturbed shade colour. Several edge layers (§3.4, repeated edges) each get
// their own matrix and colour and are laid over each other. LOC_DEPTH: the depth map read (nearest)
// at every layer's shifted coordinates and the shade map's, the minimum written for the depth sprite.
#if defined FRAGMENT_SHADER
in vec2 v_uv;
uniform sampler2D t_edges;
uniform sampler2D t_shade;
uniform sampler2D t_offset;
uniform mat2 u_shade_matrix;
uniform mat2 u_edge_matrix[LAYERS];
uniform vec3 u_edge_color[LAYERS];
uniform float u_edge_strength;
uniform float u_use_shade;
uniform vec3 u_paper;
uniform float u_line_contrast;  // a line over a fill less than this much lighter than its ink turns to paper
#ifdef HAS_SPIN
// the surface's turn in the picture since frame 0 (rasterize.spin: cos, sin; (0, 0) where nothing was drawn):
// every shift, once through its matrix, is turned by it in pixels, so a mark keeps its place beside a turning part
uniform sampler2D t_spin;
vec2 turned(vec2 off, vec2 s) {
    vec2 size = vec2(textureSize(t_shade, 0));
    vec2 px = off * size;
    return vec2(s.x * px.x - s.y * px.y, s.y * px.x + s.x * px.y) / size;
}
#define SHIFT(m) turned((m) * off, spin)
#else
#define SHIFT(m) ((m) * off)
#endif
#ifdef LOC_COLOR
layout(location = LOC_COLOR) out vec4 o_color;
#endif
#ifdef LOC_OFFSETS
layout(location = LOC_OFFSETS) out vec4 o_offsets;
#endif
#ifdef LOC_DEPTH
layout(location = LOC_DEPTH) out float o_depth;
#endif
#ifdef HAS_DEPTH
#ifdef COVER_FROM_SHADE
// Only z >= 1 (no surface) matters and the shade map is the same G-buffer's colour: its alpha is > 0
// exactly where the depth is < 1 (Sketch.unread_inputs), so the nearest shade texel answers it.
float depth_at(vec2 uv) {
    vec2 size = vec2(textureSize(t_shade, 0));
    return texelFetch(t_shade, ivec2(clamp(floor(uv * size), vec2(0.0), size - 1.0)), 0).a > 0.0 ? 0.0 : 1.0;
}
#else
uniform sampler2D t_depth;
// nearest lookup, as depth_sprite does: depth must not be blended across a silhouette
float depth_at(vec2 uv) {
    vec2 size = vec2(textureSize(t_depth, 0));
    return texelFetch(t_depth, ivec2(clamp(floor(uv * size), vec2(0.0), size - 1.0)), 0).r;
}
#endif
#endif
void main() {
    vec2 off = texelFetch(t_offset, ivec2(gl_FragCoord.xy), 0).rg;  // same grid as the output: no filtering
#ifdef HAS_SPIN
    vec2 spin = texelFetch(t_spin, ivec2(gl_FragCoord.xy), 0).rg;
    float spin_len = length(spin);
    spin = spin_len > 0.0 ? spin / spin_len : vec2(1.0, 0.0);
#endif
    vec2 shade_off = SHIFT(u_shade_matrix);
    vec4 shade = texture(t_shade, v_uv + shade_off) * u_use_shade;
    vec3 color = mix(u_paper, shade.rgb, shade.a);
    float cover = shade.a;
    // lines stay visible over dark fills: where the fill's luminance comes within u_line_contrast of an ink's
    // (a dark texture), that ink turns towards the paper colour, fully where the fill is as dark as the ink
    const vec3 LUMA = vec3(0.2126, 0.7152, 0.0722);
    float fill_luma = dot(color, LUMA);
    vec2 first_edge_off = SHIFT(u_edge_matrix[0]);
#ifdef HAS_DEPTH
    float z = u_use_shade > 0.5 ? depth_at(v_uv + shade_off) : 1.0;
#endif
    for (int i = 0; i < LAYERS; ++i) {
        vec2 edge_off = SHIFT(u_edge_matrix[i]);
        float e = clamp(texture(t_edges, v_uv + edge_off).r * u_edge_strength, 0.0, 1.0);
        float ink_luma = dot(u_edge_color[i], LUMA);
        float light = u_line_contrast > 0.0
            ? clamp((ink_luma + u_line_contrast - fill_luma) / u_line_contrast, 0.0, 1.0) : 0.0;
        color = mix(color, mix(u_edge_color[i], u_paper, light), e);
        cover = max(cover, e);
#ifdef HAS_DEPTH
        z = min(z, depth_at(v_uv + edge_off));
#endif
    }
#ifdef HAS_DEPTH
    if (z >= 1.0) {  // no surface behind this pixel: paper, as the depth sprite would show
        color = u_paper;
        cover = 0.0;
    }
#endif
#ifdef LOC_COLOR
    o_color = vec4(color, cover);
#endif
#ifdef LOC_OFFSETS
    o_offsets = vec4(first_edge_off, shade_off);
#endif
#ifdef LOC_DEPTH
    o_depth = z;
#endif
}
#endif
