#version 330
// Strokes as textured quads (the quads are built on the CPU: nodes/draw_strokes/quads.py). Pass STROKES writes
// each fragment's darkness (coverage x tone x brush x grain) into a one-channel target, blended (ink: the
// larger value; pencil and chalk: "over", so crossings darken); pass COMPOSE lays it over paper or writes it
// as alpha.
#if defined VERTEX_SHADER
#if STROKES
in vec2 in_pos;      // pixels, y up
in vec4 in_frame;    // across (signed px from the centre line), along (arc length px), beyond (px past an end), hw
in vec3 in_dir;      // unit tangent on screen (xy), tone x opacity (z)
uniform vec2 u_viewport;
out vec4 v_frame;
out vec3 v_dir;
void main() {
    v_frame = in_frame;
    v_dir = in_dir;
    gl_Position = vec4(in_pos / u_viewport * 2.0 - 1.0, 0.0, 1.0);
}
#else
void main() {
    vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
#endif

#elif defined FRAGMENT_SHADER
#if STROKES
in vec4 v_frame;
in vec3 v_dir;
uniform sampler2D t_brush;   // brush texture: u along the stroke (repeats), v across (0 .. 1)
uniform float u_soft;        // edge ramp in pixels (the coverage falls from 1 to 0 over it)
uniform float u_repeat;      // brush texture repeats every u_repeat stroke widths
uniform float u_grain;
#if PAPER
uniform sampler2D t_paper;   // grain normal (xyz) and height (w), tiled at one texel per pixel
#endif
out vec4 f_dark;
void main() {
    float hw = v_frame.w;
    float across = abs(v_frame.x);
    float r = v_frame.z > 0.0 ? length(vec2(v_frame.z, across)) : across;  // round caps past the ends
    // the ramp is centred on the edge: a straight stroke's coverage sums to its width across it
    float cover = clamp((hw + 0.5 * u_soft - r) / u_soft, 0.0, 1.0);
    if (cover <= 0.0) discard;
    vec2 uv = vec2(v_frame.y / (2.0 * hw * u_repeat), 0.5 + 0.5 * clamp(v_frame.x / hw, -1.0, 1.0));
    float dark = cover * v_dir.z * texture(t_brush, uv).r;
#if PAPER
    vec4 g = texelFetch(t_paper, ivec2(mod(gl_FragCoord.xy, vec2(textureSize(t_paper, 0)))), 0);
    dark *= clamp(1.0 + 2.5 * u_grain * dot(g.xy, v_dir.xy), 0.0, 2.0);
#endif
    f_dark = vec4(clamp(dark, 0.0, 1.0));
}
#else
uniform sampler2D t_dark;
uniform vec3 u_color;
uniform vec3 u_paper_color;
uniform float u_paper_tint;
#if PAPER
uniform sampler2D t_paper;
#endif
out vec4 f_color;
void main() {
    float d = texelFetch(t_dark, ivec2(gl_FragCoord.xy), 0).r;
#if PAPER
    vec4 g = texelFetch(t_paper, ivec2(mod(gl_FragCoord.xy, vec2(textureSize(t_paper, 0)))), 0);
    vec3 paper = u_paper_color * (1.0 - u_paper_tint * (1.0 - g.w));
    f_color = vec4(mix(paper, u_color, d), 1.0);
#else
    f_color = vec4(u_color, d);
#endif
}
#endif
#endif
