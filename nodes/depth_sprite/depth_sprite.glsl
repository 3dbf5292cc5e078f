#version 330
// Depth sprites (Nienhaus & Döllner §3.3). PASS 0 lays down what lies under the sketch (ordinary
// geometry's colour and depth, or paper at the far plane). PASS 1 draws the sketch as a screen-aligned
// quad whose fragment depth is the minimum of the depth map read at the two perturbed coordinates
// (edge shift and shade shift), or with SKETCH_DEPTH the sketch's own minimum over all its lookups
// (every repeated edge layer and the shade map); a fragment whose depth is the far plane is rejected first.
#if defined FRAGMENT_SHADER
in vec2 v_uv;
uniform sampler2D t_color;
uniform sampler2D t_offsets;
uniform sampler2D t_depth;
uniform sampler2D t_under_color;
uniform sampler2D t_under_depth;
uniform sampler2D t_sketch_depth;
uniform vec3 u_paper;
uniform float u_has_under;
layout(location = 0) out vec4 o_color;
layout(location = 1) out float o_depth;
void main() {
#if PASS == 0
    float z = 1.0;
    vec3 c = u_paper;
    if (u_has_under > 0.5) {
        vec4 under = texture(t_under_color, v_uv);
        c = mix(u_paper, under.rgb, under.a);
        z = texelFetch(t_under_depth, ivec2(gl_FragCoord.xy), 0).r;
    }
    gl_FragDepth = z;
    o_color = vec4(c, 1.0);
    o_depth = z;
#else
#if SKETCH_DEPTH
    float z = texelFetch(t_sketch_depth, ivec2(gl_FragCoord.xy), 0).r;
#else
    vec4 off = texelFetch(t_offsets, ivec2(gl_FragCoord.xy), 0);
    // nearest lookups: depth must not be blended across a silhouette
    vec2 size = vec2(textureSize(t_depth, 0));
    float z_edge = texelFetch(t_depth, ivec2(clamp(floor((v_uv + off.xy) * size), vec2(0.0), size - 1.0)), 0).r;
    float z_shade = texelFetch(t_depth, ivec2(clamp(floor((v_uv + off.zw) * size), vec2(0.0), size - 1.0)), 0).r;
    float z = min(z_edge, z_shade);
#endif
#if OVER_PAPER
    bool drawn = z < 1.0;
    o_color = vec4(drawn ? texelFetch(t_color, ivec2(gl_FragCoord.xy), 0).rgb : u_paper, 1.0);
    o_depth = drawn ? z : 1.0;
#else
    if (z >= 1.0) discard;
    gl_FragDepth = z;
    o_color = vec4(texelFetch(t_color, ivec2(gl_FragCoord.xy), 0).rgb, 1.0);
    o_depth = z;
#endif
#endif
}
#endif
