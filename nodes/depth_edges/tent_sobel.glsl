// A tent blur followed by the Sobel pair of Curtis' pseudocode (seed 004), split into one pass per axis.
// Both are separable: tent = t(x) t(y), t = [1 2 .. R+1 .. 2 1]; the seed's gx = smooth(y) diff(x) and
// gy = diff(y) smooth(x), smooth = [1 2 1], diff = I(+1) - I(-1) (read as k[x][y] with y down the image;
// on a texture, row 0 at the bottom, that is -8 x the gradient: see nodes/particle_sketch/core.py). So
// the x pass stores (smooth(t(f)), diff(t(f))) along x, and the y pass combines
// gx = -smooth(t(diff channel)), gy = -diff(t(smooth channel)) along y, unnormalised.
//
// Borders clamp to the edge texel at *both* stages, as two clamped convolutions do: the Sobel taps read
// the blur at the clamped neighbours c(p - 1), p, c(p + 1), and each of those blurs reads clamped texels.
// All of them lie in the window f(c(p + m)), m = -(R + 1) .. R + 1, which the caller fetches once.
// Define TENT_R before including.

#define TENT_W (TENT_R + 1)

// The tent at offset k (-1, 0, 1) of the window w[m + TENT_W] = f(c(p + m)).
vec2 tent_at(vec2 w[2 * TENT_W + 1], int k) {
    vec2 s = vec2(0.0);
    for (int j = -TENT_R; j <= TENT_R; ++j)
        s += float(TENT_W - abs(j)) * w[k + j + TENT_W];
    return s;
}

// The tents at c(p - 1), p, c(p + 1): at a border the clamped neighbour is p itself.
void clamped_tents(vec2 w[2 * TENT_W + 1], bool has_lo, bool has_hi, out vec2 lo, out vec2 mid, out vec2 hi) {
    mid = tent_at(w, 0);
    lo = has_lo ? tent_at(w, -1) : mid;
    hi = has_hi ? tent_at(w, 1) : mid;
}

// x pass: (smooth, diff) along x of the tent-blurred scalar f, from the window of f along x.
vec2 tent_sobel_x(vec2 w[2 * TENT_W + 1], int x, int last) {
    vec2 lo, mid, hi;
    clamped_tents(w, x > 0, x < last, lo, mid, hi);
    return vec2(lo.x + 2.0 * mid.x + hi.x, hi.x - lo.x);
}

// y pass: the seed's (gx, gy), unnormalised, from the window along y of the x pass's (smooth, diff).
vec2 tent_sobel_y(vec2 w[2 * TENT_W + 1], int y, int last) {
    vec2 lo, mid, hi;
    clamped_tents(w, y > 0, y < last, lo, mid, hi);
    return -vec2(lo.y + 2.0 * mid.y + hi.y, hi.x - lo.x);
}
