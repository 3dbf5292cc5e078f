// The Sobel pair of Curtis' loose-and-sketchy pseudocode (seed 004), as the seed writes it: convolutions
// with gx = [-1 -2 -1; 0 0 0; 1 2 1], gy = [1 0 -1; 2 0 -2; 1 0 -1] read as k[x][y] with y down the image.
// On a texture (x = column, y = row, row 0 at the bottom) that is (gx, gy) = -8 x the gradient, smoothed
// by [1 2 1] across the derivative; see nodes/particle_sketch/core.py. Borders clamp to the edge texel.
vec2 seed_sobel(sampler2D t, ivec2 p) {
    ivec2 hi = textureSize(t, 0) - 1;
    float s[9];  // s[3 * (dy + 1) + (dx + 1)]
    for (int j = 0; j < 3; ++j)
        for (int i = 0; i < 3; ++i)
            s[3 * j + i] = texelFetch(t, clamp(p + ivec2(i - 1, j - 1), ivec2(0), hi), 0).r;
    float dx = (s[2] - s[0]) + 2.0 * (s[5] - s[3]) + (s[8] - s[6]);  // I(x+1) - I(x-1), rows 1 2 1
    float dy = (s[6] - s[0]) + 2.0 * (s[7] - s[1]) + (s[8] - s[2]);  // I(y+1) - I(y-1), columns 1 2 1
    return -vec2(dx, dy);
}
