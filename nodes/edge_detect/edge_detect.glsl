#version 330
// Edge map from discontinuities in the normal and depth buffers (Nienhaus & Döllner 2003/2004 §3.1).
// Input: one RGBA32F texel per pixel, view-space normal in xyz, linear view depth in w (0 = background).
// Profile edges: depth discontinuities and the object/background boundary, marked on the near side.
// Inner edges: normal discontinuities (creases), measured as the chord |n_a - n_b| = 2 sin(angle/2).
// OPERATOR 0 = four neighbours at distance r (depth by its second difference, so slanted planes
// give none); OPERATOR 1 = 3x3 Sobel at distance r on the normal chords and the relative depth.
// A width w = RADIUS + u_frac that is not whole (BLEND 1) blends the stencils at r = RADIUS and r = RADIUS + 1
// by u_frac (r = 0 marks nothing): lines come out w pixels thick on average, so a width below one pixel
// draws a faint line of intensity w instead of vanishing, and a whole width is the single stencil.
#if defined FRAGMENT_SHADER
uniform sampler2D t_normal_depth;
uniform float u_normal_threshold;
uniform float u_depth_threshold;
uniform float u_profile_intensity;
uniform float u_inner_intensity;
// RADIUS (define): whole part of the width in pixels; BLEND (define): 1 where the width has a fraction
uniform float u_frac;   // fractional part: weight of the stencil at RADIUS + 1
#ifdef LOC_OUT
layout(location = LOC_OUT) out float o_out;
#endif
#ifdef LOC_PROFILE
layout(location = LOC_PROFILE) out float o_profile;
#endif
#ifdef LOC_INNER
layout(location = LOC_INNER) out float o_inner;
#endif

ivec2 g_max;
ivec2 g_px;
vec4 g_c;

// A neighbour; background reads as far behind the centre with the centre's normal (no crease:
// the profile covers that boundary).
vec4 at(ivec2 o) {
    vec4 s = texelFetch(t_normal_depth, clamp(g_px + o, ivec2(0), g_max), 0);
    return s.w > 0.0 ? s : vec4(g_c.xyz, g_c.w * 4.0);
}
float chord2(vec4 a, vec4 b) { vec3 d = a.xyz - b.xyz; return dot(d, d); }

// profile and inner edge measures of the centre pixel with the stencil at distance r (>= 1)
void measure(int r, out float profile, out float inner) {
    profile = 0.0;
    inner = 0.0;
#if OPERATOR == 0
    vec4 l = at(ivec2(-r, 0)), rr = at(ivec2(r, 0)), d = at(ivec2(0, -r)), u = at(ivec2(0, r));
    // second differences, relative: > 0 when the centre lies in front of its neighbours' mean
    float depth_measure = (max(l.w + rr.w, d.w + u.w) - 2.0 * g_c.w) / g_c.w;
    float normal_measure = sqrt(max(max(chord2(g_c, l), chord2(g_c, rr)), max(chord2(g_c, d), chord2(g_c, u))));
#else
    vec4 s[9];
    for (int j = 0; j < 3; ++j)
        for (int i = 0; i < 3; ++i)
            s[j * 3 + i] = at(ivec2(i - 1, j - 1) * r);
    float gx = (s[2].w + 2.0 * s[5].w + s[8].w) - (s[0].w + 2.0 * s[3].w + s[6].w);
    float gy = (s[6].w + 2.0 * s[7].w + s[8].w) - (s[0].w + 2.0 * s[1].w + s[2].w);
    float depth_measure = length(vec2(gx, gy)) / (4.0 * g_c.w);
    float nx = sqrt(chord2(s[0], s[2])) + 2.0 * sqrt(chord2(s[3], s[5])) + sqrt(chord2(s[6], s[8]));
    float ny = sqrt(chord2(s[0], s[6])) + 2.0 * sqrt(chord2(s[1], s[7])) + sqrt(chord2(s[2], s[8]));
    float normal_measure = length(vec2(nx, ny)) / 4.0;
#endif
#if USE_DEPTH
    profile = smoothstep(u_depth_threshold, 1.5 * u_depth_threshold, depth_measure);
#endif
#if USE_NORMAL
    inner = smoothstep(u_normal_threshold, 1.25 * u_normal_threshold, normal_measure);
#endif
}

void main() {
    g_max = textureSize(t_normal_depth, 0) - 1;
    g_px = ivec2(gl_FragCoord.xy);
    g_c = texelFetch(t_normal_depth, g_px, 0);
    float profile = 0.0;
    float inner = 0.0;
    if (g_c.w > 0.0) {
#if RADIUS > 0
        measure(RADIUS, profile, inner);
#endif
#if BLEND
        float profile1, inner1;
        measure(RADIUS + 1, profile1, inner1);
        profile = mix(profile, profile1, u_frac);
        inner = mix(inner, inner1, u_frac);
#endif
    }
#ifdef LOC_OUT
    o_out = max(profile * u_profile_intensity, inner * u_inner_intensity);
#endif
#ifdef LOC_PROFILE
    o_profile = profile;
#endif
#ifdef LOC_INNER
    o_inner = inner;
#endif
}
#endif
