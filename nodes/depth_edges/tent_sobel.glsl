// A tent blur followed by the Sobel pair of Curtis' pseudocode (seed 004), split into one pass per axis.
// Both are separable: tent = t(x) t(y), and the seed's gx = smooth(y) diff(x), gy = diff(y) smooth(x),
// smooth = [1 2 1], diff = I(+1) - I(-1) (read as k[x][y] with y down the image; on a texture, row 0 at the
// bottom, that is -8 x the gradient: see nodes/particle_sketch/core.py). So the x pass stores
// (smooth(t(f)), diff(t(f))) along x, and the y pass combines gx = -smooth(t(diff channel)),
// gy = -diff(t(smooth channel)) along y, unnormalised (divide by u_tent_norm, the tent's sum squared).
//
// The 1-D weights are uniforms (nodes/_shared/scaled_kernels.py): at px_scale 1 the seed's tent, [1 2 1] and
// [-1 0 1]; at other scales the same kernels with their footprint in pixels at the reference size
// (radius TENT_R of the tent, SOBEL_R of the Sobel pair; both defines are set before including).
//
// Borders clamp to the edge texel at *both* stages, as two clamped convolutions do: the Sobel taps read
// the blur at the clamped neighbours c(p + k), k = -SOBEL_R .. SOBEL_R, and each of those blurs reads
// clamped texels. All of them lie in the window f(c(p + m)), m = -WIN_R .. WIN_R, which the caller
// fetches once.

#define WIN_R (TENT_R + SOBEL_R)

uniform float u_tent[2 * TENT_R + 1];
uniform float u_smooth[2 * SOBEL_R + 1];
uniform float u_diff[2 * SOBEL_R + 1];
uniform float u_tent_norm;

// The tent at offset k of the window w[m + WIN_R] = f(c(p + m)); k is a constant wherever it is called.
vec2 tent_at(vec2 w[2 * WIN_R + 1], int k) {
    vec2 s = vec2(0.0);
    for (int j = -TENT_R; j <= TENT_R; ++j)
        s += u_tent[j + TENT_R] * w[k + j + WIN_R];
    return s;
}

// (smooth, diff) of the tents at the clamped neighbours c(p + k) (at a border the clamped neighbour is
// nearer p: its offset is c(p + k) - p). The tents are formed at the constant offsets -SOBEL_R .. SOBEL_R
// and only the choice among them depends on the pixel: an array indexed by a value that differs between
// pixels becomes a chain of selects over all its elements on llvmpipe, which for the window itself (9 tent
// taps x 3 Sobel taps into 11 elements for force_field) cost more than the arithmetic: over the whole image
// of spot at 800x800, force_field 66.8 -> 47.6 ms and depth_edges 33.7 -> 27.0 ms (one run each). The same
// sums in the same order, so the same bits (the gallery's images are unchanged).
// (smooth, diff) from the tents at the clamped neighbours t[k + SOBEL_R] = T(c(p + k)).
mat2 sobel_of(vec2 t[2 * SOBEL_R + 1]) {
    vec2 sm = vec2(0.0);
    vec2 df = vec2(0.0);
    for (int k = -SOBEL_R; k <= SOBEL_R; ++k) {
        sm += u_smooth[k + SOBEL_R] * t[k + SOBEL_R];
        df += u_diff[k + SOBEL_R] * t[k + SOBEL_R];
    }
    return mat2(sm, df);
}

mat2 smooth_diff(vec2 w[2 * WIN_R + 1], int p, int last) {
    vec2 t[2 * SOBEL_R + 1];
    for (int k = -SOBEL_R; k <= SOBEL_R; ++k)
        t[k + SOBEL_R] = tent_at(w, k);
    vec2 c[2 * SOBEL_R + 1];
    for (int k = -SOBEL_R; k <= SOBEL_R; ++k)
        c[k + SOBEL_R] = t[clamp(p + k, 0, last) - p + SOBEL_R];
    return sobel_of(c);
}

// x pass: (smooth, diff) along x of the tent-blurred scalar f, from the window of f along x.
vec2 tent_sobel_x(vec2 w[2 * WIN_R + 1], int x, int last) {
    mat2 sd = smooth_diff(w, x, last);
    return vec2(sd[0].x, sd[1].x);
}

// y pass: the seed's (gx, gy), unnormalised, from the window along y of the x pass's (smooth, diff).
vec2 tent_sobel_y(vec2 w[2 * WIN_R + 1], int y, int last) {
    mat2 sd = smooth_diff(w, y, last);
    return -vec2(sd[0].y, sd[1].x);
}

// Split passes. Forming the tent at every Sobel tap costs the product of the two widths (force_field's 19 x 7 taps at
// twice the reference size); above `scaled_kernels.SPLIT_ABOVE` the nodes run each axis as two passes instead: the
// tent into a texture (PASS 2 along x, the node's own input; PASS 4 along y, generic below), then the Sobel pair
// from it at the clamped neighbours (PASS 3 along x, generic below; PASS 5 along y, the node's own output). The same
// sums in the same order as tent_at and smooth_diff, so the same bits (tests/nodes/depth_edges).
vec2 tent_of(vec2 w[2 * TENT_R + 1]) {
    vec2 s = vec2(0.0);
    for (int j = -TENT_R; j <= TENT_R; ++j)
        s += u_tent[j + TENT_R] * w[j + TENT_R];
    return s;
}

#if PASS == 3 || PASS == 4
uniform sampler2D t_t;
layout(location = 0) out vec2 o_t;

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    ivec2 hi = textureSize(t_t, 0) - 1;
#if PASS == 3
    // x pass, second half: (smooth, diff) along x of the scalar tent (both channels hold it)
    vec2 t[2 * SOBEL_R + 1];
    for (int k = -SOBEL_R; k <= SOBEL_R; ++k)
        t[k + SOBEL_R] = texelFetch(t_t, ivec2(clamp(p.x + k, 0, hi.x), p.y), 0).xy;
    mat2 sd = sobel_of(t);
    o_t = vec2(sd[0].x, sd[1].x);
#else
    // y pass, first half: the tent along y of the x pass's (smooth, diff)
    vec2 w[2 * TENT_R + 1];
    for (int j = -TENT_R; j <= TENT_R; ++j)
        w[j + TENT_R] = texelFetch(t_t, ivec2(p.x, clamp(p.y + j, 0, hi.y)), 0).xy;
    o_t = tent_of(w);
#endif
}
#endif

// y pass, second half (PASS 5): the seed's (gx, gy), unnormalised, from the y tents of the x pass's (smooth, diff).
vec2 sobel_y_from(sampler2D tents, ivec2 p) {
    int last = textureSize(tents, 0).y - 1;
    vec2 t[2 * SOBEL_R + 1];
    for (int k = -SOBEL_R; k <= SOBEL_R; ++k)
        t[k + SOBEL_R] = texelFetch(tents, ivec2(p.x, clamp(p.y + k, 0, last)), 0).xy;
    mat2 sd = sobel_of(t);
    return -vec2(sd[0].y, sd[1].x);
}
