#version 330
// Posterize: each channel to u_levels evenly spaced values,
// q(c) = min(floor(clamp(c, 0, 1) * u_levels), u_levels - 1) / (u_levels - 1).
// POSTERIZE_ALPHA (0/1): quantise alpha too; otherwise alpha passes unchanged.
// Fragment stage only: the engine supplies its full-screen triangle as the vertex stage.
#if defined FRAGMENT_SHADER
uniform sampler2D t_color;
uniform int u_levels;
layout(location = 0) out vec4 o_color;

vec4 posterize(vec4 c) {
    float n = float(u_levels);
    return min(floor(clamp(c, 0.0, 1.0) * n), n - 1.0) / (n - 1.0);
}

void main() {
    vec4 c = texelFetch(t_color, ivec2(gl_FragCoord.xy), 0);
    vec4 q = posterize(c);
#if POSTERIZE_ALPHA
    o_color = q;
#else
    o_color = vec4(q.rgb, c.a);
#endif
}
#endif
