#version 330
// The composite pass of the previous implementation (geometry_shader.py). Final pencil image: hatching value times contour value (graphite over graphite darkens), graphite
// over paper whose relief shows faintly.
#if defined FRAGMENT_SHADER
in vec2 v_uv;
uniform sampler2D t_shade;    // hatching, 1 = paper
#if CONTOUR
uniform sampler2D t_contour;  // contours, 1 = paper
#endif
#if PAPER
uniform sampler2D t_paper;    // grain normal (xyz), height (w)
#endif
uniform vec3 u_paper_color;
uniform vec3 u_graphite_color;
uniform float u_paper_tint;
out vec4 o_color;

void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    float value = texelFetch(t_shade, px, 0).r;
#if CONTOUR
#if CONTOUR_SAME_SIZE
    value *= texelFetch(t_contour, px, 0).r;
#else
    value *= texture(t_contour, v_uv).r;
#endif
#endif
    vec3 paper = u_paper_color;
#if PAPER
    ivec2 tile = ivec2(mod(gl_FragCoord.xy, vec2(textureSize(t_paper, 0))));  // float mod: integer % is slow on llvmpipe
    paper *= 1.0 - u_paper_tint * (1.0 - texelFetch(t_paper, tile, 0).w);
#endif
    o_color = vec4(mix(u_graphite_color, paper, clamp(value, 0.0, 1.0)), 1.0);
}
#endif
