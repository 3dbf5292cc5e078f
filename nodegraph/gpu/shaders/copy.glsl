#version 330
// A plain full-screen copy: the floor for one image-space pass.
#if defined FRAGMENT_SHADER
uniform sampler2D t_src;
layout(location = 0) out vec4 o_color;
void main() { o_color = texelFetch(t_src, ivec2(gl_FragCoord.xy), 0); }
#endif
