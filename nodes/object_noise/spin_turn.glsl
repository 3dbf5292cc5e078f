#version 330
// object_noise with `spin` connected: the pair (off_s, off_t) turned by the angle the surface under the pixel has
// turned in the picture since frame 0 (rasterize.spin, (cos, sin); (0, 0) where nothing was drawn: unturned), so a
// mark keeps its place beside the surface as the picture turns. Same grid as the noise: texel fetches.
#if defined FRAGMENT_SHADER
uniform sampler2D t_noise;
uniform sampler2D t_spin;
layout(location = 0) out vec2 o_out;
void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    vec2 v = texelFetch(t_noise, p, 0).rg;
    vec2 s = texelFetch(t_spin, p, 0).rg;
    float n = length(s);
    if (n > 0.0) {
        s /= n;
        v = vec2(s.x * v.x - s.y * v.y, s.y * v.x + s.x * v.y);
    }
    o_out = v;
}
#endif
