#version 330
// A layer over (or multiplied onto) a base image. The layer's colour is t_top.rgb (HAS_TOP) or u_color;
// its alpha is t_mask.r (HAS_MASK) or t_top.a, times u_opacity.
// MODE 0 (over):     rgb = mix(base, layer, a), alpha = a + base.a (1 - a)
// MODE 1 (multiply): rgb = base * mix(1, layer, a), alpha = base.a
#if defined FRAGMENT_SHADER
uniform sampler2D t_base;
#if HAS_TOP
uniform sampler2D t_top;
#endif
#if HAS_MASK
uniform sampler2D t_mask;
#endif
uniform vec3 u_color;
uniform float u_opacity;
layout(location = 0) out vec4 o_color;

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec4 base = texelFetch(t_base, p, 0);
#if HAS_TOP
    vec4 top = texelFetch(t_top, p, 0);
#else
    vec4 top = vec4(u_color, 1.0);
#endif
#if HAS_MASK
    float a = texelFetch(t_mask, p, 0).r;
#else
    float a = top.a;
#endif
    a = clamp(a * u_opacity, 0.0, 1.0);
#if MODE == 0
    o_color = vec4(mix(base.rgb, top.rgb, a), a + base.a * (1.0 - a));
#else
    o_color = vec4(base.rgb * mix(vec3(1.0), top.rgb, a), base.a);
#endif
}
#endif
