#version 330
// Copy a texture texel for texel (rasterize: the float32 normal that tone bands read, into the port's format).
#if defined FRAGMENT_SHADER
uniform sampler2D t_in;
out vec4 o_out;
void main() {
    o_out = texelFetch(t_in, ivec2(gl_FragCoord.xy), 0);
}
#endif
