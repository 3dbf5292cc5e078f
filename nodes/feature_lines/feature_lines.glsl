#version 330
// Feature-line segments (object space, extracted on the CPU) drawn as screen-space quads `u_width` pixels
// wide. Occlusion: the point on the segment's centre line is compared with the G-buffer's linear depth at
// its own pixel (so a quad that overhangs a silhouette is judged where the line is, not where it spills).
// Overlaps keep the largest intensity: the fragment depth is 1 - intensity under the depth test "<".
#if defined VERTEX_SHADER
in vec3 in_pos;
in float in_intensity;
uniform mat4 u_model;
uniform mat4 u_view;
uniform mat4 u_proj;
out float v_intensity;
out float v_depth;
void main() {
    vec4 view = u_view * u_model * vec4(in_pos, 1.0);
    v_intensity = in_intensity;
    v_depth = -view.z;
    gl_Position = u_proj * view;
}

#elif defined GEOMETRY_SHADER
layout(lines) in;
layout(triangle_strip, max_vertices = 4) out;
in float v_intensity[];
in float v_depth[];
uniform vec2 u_viewport;
uniform float u_width;
out float f_intensity;
out float f_depth;
noperspective out vec2 f_center;  // pixel position of the centre line

void main() {
    vec4 c0 = gl_in[0].gl_Position, c1 = gl_in[1].gl_Position;
    if (c0.w <= 0.0 || c1.w <= 0.0) return;
    vec2 s0 = (c0.xy / c0.w * 0.5 + 0.5) * u_viewport;
    vec2 s1 = (c1.xy / c1.w * 0.5 + 0.5) * u_viewport;
    vec2 d = s1 - s0;
    d = dot(d, d) > 1e-12 ? normalize(d) : vec2(1.0, 0.0);
    vec2 nrm = vec2(-d.y, d.x);
    float hw = 0.5 * u_width;
    for (int k = 0; k < 4; ++k) {
        int end = k / 2;
        float side = (k % 2 == 0) ? -1.0 : 1.0;
        vec4 c = end == 0 ? c0 : c1;
        vec2 s = end == 0 ? s0 : s1;
        vec2 off = hw * (side * nrm + (end == 0 ? -d : d));
        gl_Position = vec4(c.xy + off / u_viewport * 2.0 * c.w, c.z, c.w);
        f_intensity = v_intensity[end];
        f_depth = v_depth[end];
        f_center = s + (end == 0 ? -d : d) * hw;
        EmitVertex();
    }
    EndPrimitive();
}

#elif defined FRAGMENT_SHADER
in float f_intensity;
in float f_depth;
noperspective in vec2 f_center;
uniform sampler2D t_normal_depth;
#if EDGES
uniform sampler2D t_edges;
#endif
uniform float u_depth_tolerance;
uniform float u_scale;
out float o_out;
void main() {
    ivec2 size = textureSize(t_normal_depth, 0);
    ivec2 px = clamp(ivec2(f_center), ivec2(0), size - 1);
    float d = texelFetch(t_normal_depth, px, 0).w;
    if (d > 0.0 && f_depth > d * (1.0 + u_depth_tolerance)) discard;
    float value = clamp(f_intensity * u_scale, 0.0, 1.0);
#if EDGES
    value = max(value, texelFetch(t_edges, ivec2(gl_FragCoord.xy), 0).r);
#endif
    if (value <= 0.0) discard;
    o_out = value;
    gl_FragDepth = 1.0 - value;
}
#endif
