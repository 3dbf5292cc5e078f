#version 330
// The drawing from the ink coverage of the particle strokes: the line colour over the paper colour.
#if defined FRAGMENT_SHADER
uniform sampler2D t_ink;
uniform vec3 u_color;
uniform vec3 u_paper;
layout(location = 0) out vec4 o_image;

void main() {
    float ink = texelFetch(t_ink, ivec2(gl_FragCoord.xy), 0).r;
    o_image = vec4(mix(u_paper, u_color, ink), 1.0);
}
#endif
