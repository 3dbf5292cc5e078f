#version 330
// Edge map from discontinuities in the normal and depth buffers (Nienhaus & Döllner 2003/2004 §3.1).
// Profile edges: depth discontinuities and the object/background boundary, marked on the near side.
// Inner edges: normal discontinuities (creases), measured as the chord |n_a - n_b| = 2 sin(angle/2).
// OPERATOR 0 = four neighbours at distance u_width (depth by its second difference, so slanted planes
// give none); OPERATOR 1 = 3x3 Sobel at distance u_width on the normal chords and the relative depth.
#if defined FRAGMENT_SHADER
uniform sampler2D t_normal;
uniform sampler2D t_depth;           // linear view depth; 0 = background
uniform float u_normal_threshold;
uniform float u_depth_threshold;
uniform float u_profile_intensity;
uniform float u_inner_intensity;
uniform int u_width;
#ifdef LOC_OUT
layout(location = LOC_OUT) out float o_out;
#endif
#ifdef LOC_PROFILE
layout(location = LOC_PROFILE) out float o_profile;
#endif
#ifdef LOC_INNER
layout(location = LOC_INNER) out float o_inner;
#endif

ivec2 g_size;
ivec2 g_px;

float depth_at(ivec2 o, float dc) {
    float d = texelFetch(t_depth, clamp(g_px + o, ivec2(0), g_size - 1), 0).r;
    return d > 0.0 ? d : dc * 4.0;   // background reads as far behind the centre
}
vec3 normal_at(ivec2 o, vec3 nc) {
    vec4 n = texelFetch(t_normal, clamp(g_px + o, ivec2(0), g_size - 1), 0);
    return n.a > 0.5 ? n.xyz : nc;    // background: no normal discontinuity (the profile covers it)
}
float chord(vec3 a, vec3 b) { return length(a - b); }

void main() {
    g_size = textureSize(t_depth, 0);
    g_px = ivec2(gl_FragCoord.xy);
    float dc = texelFetch(t_depth, g_px, 0).r;
    float profile = 0.0;
    float inner = 0.0;
    if (dc > 0.0) {
        vec3 nc = texelFetch(t_normal, g_px, 0).xyz;
        int r = u_width;
#if OPERATOR == 0
        float dl = depth_at(ivec2(-r, 0), dc), dr = depth_at(ivec2(r, 0), dc);
        float dd = depth_at(ivec2(0, -r), dc), du = depth_at(ivec2(0, r), dc);
        // second differences, relative: > 0 when the centre lies in front of its neighbours' mean
        float sx = (dl + dr - 2.0 * dc) / dc;
        float sy = (dd + du - 2.0 * dc) / dc;
        float depth_measure = max(sx, sy);
        float normal_measure = max(max(chord(nc, normal_at(ivec2(-r, 0), nc)), chord(nc, normal_at(ivec2(r, 0), nc))),
                                   max(chord(nc, normal_at(ivec2(0, -r), nc)), chord(nc, normal_at(ivec2(0, r), nc))));
#else
        float d[9];
        vec3 n[9];
        for (int j = 0; j < 3; ++j)
            for (int i = 0; i < 3; ++i) {
                ivec2 o = ivec2(i - 1, j - 1) * r;
                d[j * 3 + i] = depth_at(o, dc);
                n[j * 3 + i] = normal_at(o, nc);
            }
        float gx = (d[2] + 2.0 * d[5] + d[8]) - (d[0] + 2.0 * d[3] + d[6]);
        float gy = (d[6] + 2.0 * d[7] + d[8]) - (d[0] + 2.0 * d[1] + d[2]);
        float depth_measure = length(vec2(gx, gy)) / (4.0 * dc);
        float nx = chord(n[0], n[2]) + 2.0 * chord(n[3], n[5]) + chord(n[6], n[8]);
        float ny = chord(n[0], n[6]) + 2.0 * chord(n[1], n[7]) + chord(n[2], n[8]);
        float normal_measure = length(vec2(nx, ny)) / 4.0;
#endif
#if USE_DEPTH
        profile = smoothstep(u_depth_threshold, 1.5 * u_depth_threshold, depth_measure);
#endif
#if USE_NORMAL
        inner = smoothstep(u_normal_threshold, 1.25 * u_normal_threshold, normal_measure);
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
