#version 330
// A texture as 8-bit file values, the same numbers as imageio.to_uint8 on its float read-back: x * 255 in
// float32, rounded half to even (NumPy's rint), clamped to [0, 255]; NaN becomes 0 (what NumPy's cast gives
// here). Integer output, so no unorm conversion can round again. Rows are written top first (file order).
#if defined FRAGMENT_SHADER
uniform sampler2D t_src;
uniform int u_height;
layout(location = 0) out uvec4 o_bytes;
void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec4 x = texelFetch(t_src, ivec2(p.x, u_height - 1 - p.y), 0);
    vec4 v = clamp(roundEven(x * 255.0), 0.0, 255.0);
    v = mix(v, vec4(0.0), isnan(x));
    o_bytes = uvec4(v);
}
#endif
