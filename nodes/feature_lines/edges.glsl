#version 330
// The edge map the feature lines are combined with, copied into `out` before the lines are drawn over it.
#if defined FRAGMENT_SHADER
uniform sampler2D t_edges;
out float o_out;
void main() { o_out = texelFetch(t_edges, ivec2(gl_FragCoord.xy), 0).r; }
#endif
