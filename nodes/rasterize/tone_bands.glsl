#version 330
// Tone bands for the shade map (rasterize `tone_bands`): the flat colour times a step function of N.L,
// so a one-colour object shows two or three colour patches for the sketch to shift (Nienhaus & Döllner
// §3.2 read on single-colour meshes). Thresholds and factors come from the node (TONE_BANDS doc).
#if defined FRAGMENT_SHADER
uniform sampler2D t_color;   // flat colour, alpha = coverage
uniform sampler2D t_normal;  // view-space unit normal (two-sided), alpha = coverage
uniform vec3 u_light;        // view-space unit direction towards the light
uniform vec2 u_thresholds;   // N.L where the dark band ends and where the light band starts
uniform vec3 u_factors;      // dark, middle, light
out vec4 o_color;
void main() {
    ivec2 px = ivec2(gl_FragCoord.xy);
    vec4 c = texelFetch(t_color, px, 0);
    vec3 n = texelFetch(t_normal, px, 0).xyz;
    float d = dot(n, u_light);
    float f = d < u_thresholds.x ? u_factors.x : (d < u_thresholds.y ? u_factors.y : u_factors.z);
    o_color = c.a > 0.0 ? vec4(c.rgb * f, c.a) : c;
}
#endif
