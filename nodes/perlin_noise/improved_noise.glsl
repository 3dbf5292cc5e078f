// Ken Perlin's improved noise, turbulence, fbm and uint hashing for GLSL 330; an include file (no
// #version, no main). It computes what nodes/perlin_noise/reference.py computes in float64; the mapping
// of pixels and seeds is documented there. Perlin's permutation is a constant array (reference.PERM);
// llvmpipe reads it 2.4x faster than an R8UI lookup texture (4 octaves at 800x800: 77 -> 32 ms).
// Screen-space noise (NOISE_GRAD_TABLE) goes further: its z is fixed per octave, so a cell's eight corner
// hashes are one texel of a table made on the CPU for that z (noise.gradient_table).
//
// Precision: a coordinate is passed as p + cell + frac. p is split exactly into floor and fraction,
// the integer cell (a seed offset) only ever reaches the lattice index, and the small fractional
// parts are added in [0, 2), so float32 error stays ~1e-7 in noise units however large p or the
// offset is (|p| < 2^24). Octave i scales p and frac by 2^i, which is exact.
#ifndef IMPROVED_NOISE_GLSL
#define IMPROVED_NOISE_GLSL

const int NOISE_TURBULENCE = 0;
const int NOISE_FBM = 1;
// reference.CHANNEL1_OFFSET = (128.5, 85.25, 42.75), split into cell and fraction
const ivec3 NOISE_CHANNEL1_CELL = ivec3(128, 85, 42);
const vec3 NOISE_CHANNEL1_FRAC = vec3(0.5, 0.25, 0.75);

// Perlin's permutation as a constant array: llvmpipe reads it far faster than an integer texture.
const int NOISE_PERM[256] = int[256](151, 160, 137, 91, 90, 15, 131, 13, 201, 95, 96, 53, 194, 233, 7, 225, 140, 36, 103, 30, 69, 142, 8, 99, 37, 240, 21, 10, 23, 190, 6, 148, 247, 120, 234, 75, 0, 26, 197, 62, 94, 252, 219, 203, 117, 35, 11, 32, 57, 177, 33, 88, 237, 149, 56, 87, 174, 20, 125, 136, 171, 168, 68, 175, 74, 165, 71, 134, 139, 48, 27, 166, 77, 146, 158, 231, 83, 111, 229, 122, 60, 211, 133, 230, 220, 105, 92, 41, 55, 46, 245, 40, 244, 102, 143, 54, 65, 25, 63, 161, 1, 216, 80, 73, 209, 76, 132, 187, 208, 89, 18, 169, 200, 196, 135, 130, 116, 188, 159, 86, 164, 100, 109, 198, 173, 186, 3, 64, 52, 217, 226, 250, 124, 123, 5, 202, 38, 147, 118, 126, 255, 82, 85, 212, 207, 206, 59, 227, 47, 16, 58, 17, 182, 189, 28, 42, 223, 183, 170, 213, 119, 248, 152, 2, 44, 154, 163, 70, 221, 153, 101, 155, 167, 43, 172, 9, 129, 22, 39, 253, 19, 98, 108, 110, 79, 113, 224, 232, 178, 185, 112, 104, 218, 246, 97, 228, 251, 34, 242, 193, 238, 210, 144, 12, 191, 179, 162, 241, 81, 51, 145, 235, 249, 14, 239, 107, 49, 192, 214, 31, 181, 199, 106, 157, 184, 84, 204, 176, 115, 121, 50, 45, 127, 4, 150, 254, 138, 236, 205, 93, 222, 114, 67, 29, 24, 72, 243, 141, 128, 195, 78, 66, 215, 61, 156, 180);
int noise_perm(int i) { return NOISE_PERM[i & 255]; }

float noise_fade(float t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); }

float noise_lerp(float t, float a, float b) { return a + t * (b - a); }

float noise_grad(int hash, float x, float y, float z) {
    int h = hash & 15;
    float u = h < 8 ? x : y;
    float v = h < 4 ? y : (h == 12 || h == 14 ? x : z);
    return ((h & 1) == 0 ? u : -u) + ((h & 2) == 0 ? v : -v);
}

// Improved noise at p + cell + frac.
float improved_noise_split(vec3 p, ivec3 cell, vec3 frac) {
    vec3 pf = floor(p);
    vec3 qf = floor(frac);
    vec3 r = (p - pf) + (frac - qf);  // both differences exact; r in [0, 2)
    vec3 rf = floor(r);
    vec3 f = r - rf;
    ivec3 c = (cell + ivec3(pf) + ivec3(qf) + ivec3(rf)) & 255;
    int X = c.x, Y = c.y, Z = c.z;
    float x = f.x, y = f.y, z = f.z;
    float u = noise_fade(x), v = noise_fade(y), w = noise_fade(z);
    int A = noise_perm(X) + Y;
    int AA = noise_perm(A) + Z;
    int AB = noise_perm(A + 1) + Z;
    int B = noise_perm(X + 1) + Y;
    int BA = noise_perm(B) + Z;
    int BB = noise_perm(B + 1) + Z;
    return noise_lerp(w,
        noise_lerp(v, noise_lerp(u, noise_grad(noise_perm(AA), x, y, z),
                                    noise_grad(noise_perm(BA), x - 1.0, y, z)),
                      noise_lerp(u, noise_grad(noise_perm(AB), x, y - 1.0, z),
                                    noise_grad(noise_perm(BB), x - 1.0, y - 1.0, z))),
        noise_lerp(v, noise_lerp(u, noise_grad(noise_perm(AA + 1), x, y, z - 1.0),
                                    noise_grad(noise_perm(BA + 1), x - 1.0, y, z - 1.0)),
                      noise_lerp(u, noise_grad(noise_perm(AB + 1), x, y - 1.0, z - 1.0),
                                    noise_grad(noise_perm(BB + 1), x - 1.0, y - 1.0, z - 1.0))));
}

float improved_noise(vec3 p) { return improved_noise_split(p, ivec3(0), vec3(0.0)); }

#ifdef NOISE_GRAD_TABLE
// Screen-space noise (z the same for every pixel of an octave): the eight corner hashes of lattice cell (X, Y)
// come from one texel of layer `octave` (noise.gradient_table, built for that octave's z), 4 bits each, instead
// of twelve permutation lookups; the same hashes, so the same values. Layer i is octave i.
uniform usampler2DArray t_noise_grad;

float improved_noise_table(vec3 p, ivec3 cell, vec3 frac, int octave) {
    vec3 pf = floor(p);
    vec3 qf = floor(frac);
    vec3 r = (p - pf) + (frac - qf);
    vec3 rf = floor(r);
    vec3 f = r - rf;
    ivec3 c = (cell + ivec3(pf) + ivec3(qf) + ivec3(rf)) & 255;
    uint g = texelFetch(t_noise_grad, ivec3(c.x, c.y, octave), 0).r;
    float x = f.x, y = f.y, z = f.z;
    float u = noise_fade(x), v = noise_fade(y), w = noise_fade(z);
    return noise_lerp(w,
        noise_lerp(v, noise_lerp(u, noise_grad(int(g & 15u), x, y, z),
                                    noise_grad(int((g >> 4u) & 15u), x - 1.0, y, z)),
                      noise_lerp(u, noise_grad(int((g >> 8u) & 15u), x, y - 1.0, z),
                                    noise_grad(int((g >> 12u) & 15u), x - 1.0, y - 1.0, z))),
        noise_lerp(v, noise_lerp(u, noise_grad(int((g >> 16u) & 15u), x, y, z - 1.0),
                                    noise_grad(int((g >> 20u) & 15u), x - 1.0, y, z - 1.0)),
                      noise_lerp(u, noise_grad(int((g >> 24u) & 15u), x, y - 1.0, z - 1.0),
                                    noise_grad(int(g >> 28u), x - 1.0, y - 1.0, z - 1.0))));
}

float noise_octaves_table(vec3 p, ivec3 cell, vec3 frac, int octaves, int mode) {
    float sum = 0.0;
    float k = 1.0;
    ivec3 c = cell & 255;
    for (int i = 0; i < octaves; ++i) {
        float n = improved_noise_table(p * k, c, frac * k, i);
        sum += (mode == NOISE_FBM ? n : abs(n)) / k;
        k *= 2.0;
        c = (c * 2) & 255;
    }
    return sum;
}
#endif


// sum over i < octaves of |noise(2^i q)| / 2^i (mode NOISE_TURBULENCE) or noise(2^i q) / 2^i
// (NOISE_FBM), q = p + cell + frac.
float noise_octaves_split(vec3 p, ivec3 cell, vec3 frac, int octaves, int mode) {
    float sum = 0.0;
    float k = 1.0;
    ivec3 c = cell & 255;
    for (int i = 0; i < octaves; ++i) {
        float n = improved_noise_split(p * k, c, frac * k);
        sum += (mode == NOISE_FBM ? n : abs(n)) / k;
        k *= 2.0;
        c = (c * 2) & 255;
    }
    return sum;
}

float turbulence_split(vec3 p, ivec3 cell, vec3 frac, int octaves) {
    return noise_octaves_split(p, cell, frac, octaves, NOISE_TURBULENCE);
}

float fbm_split(vec3 p, ivec3 cell, vec3 frac, int octaves) {
    return noise_octaves_split(p, cell, frac, octaves, NOISE_FBM);
}

float turbulence(vec3 p, int octaves) { return turbulence_split(p, ivec3(0), vec3(0.0), octaves); }

float fbm(vec3 p, int octaves) { return fbm_split(p, ivec3(0), vec3(0.0), octaves); }

// reference.screen_offsets for one pixel: frag_coord = gl_FragCoord.xy (= (s*W, t*H)), size = (W, H),
// scale_split = reference.split_scale(scale), (seed_cell, seed_frac) = reference.seed_offset_parts(seed).
vec2 screen_offset(vec2 frag_coord, vec2 size, vec2 scale_split, ivec3 seed_cell, vec3 seed_frac,
                   int octaves, int mode) {
    vec2 a = frag_coord;         // (s, t) * (W, H)
    vec2 b = size - frag_coord;  // (1 - s, 1 - t) * (W, H), exact
#ifdef NOISE_GRAD_TABLE
    float off_s = noise_octaves_table(vec3(a * scale_split.x, 0.0), seed_cell,
                                      seed_frac + vec3(a * scale_split.y, 0.0), octaves, mode);
    float off_t = noise_octaves_table(vec3(b * scale_split.x, 0.0), seed_cell,
                                      seed_frac + vec3(b * scale_split.y, 0.0), octaves, mode);
#else
    float off_s = noise_octaves_split(vec3(a * scale_split.x, 0.0), seed_cell,
                                      seed_frac + vec3(a * scale_split.y, 0.0), octaves, mode);
    float off_t = noise_octaves_split(vec3(b * scale_split.x, 0.0), seed_cell,
                                      seed_frac + vec3(b * scale_split.y, 0.0), octaves, mode);
#endif
    return vec2(off_s, off_t);
}

// reference.noise3_at for one object-space point.
vec2 noise3_at(vec3 point, float scale, ivec3 seed_cell, vec3 seed_frac, int octaves, int mode) {
    vec3 q = point * scale;
    return vec2(noise_octaves_split(q, seed_cell, seed_frac, octaves, mode),
                noise_octaves_split(q, seed_cell + NOISE_CHANNEL1_CELL, seed_frac + NOISE_CHANNEL1_FRAC,
                                    octaves, mode));
}

// PCG hash (Jarzynski & Olano 2020): LCG step, then PCG's RXS-M-XS output permutation.
uint hash_u32(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// Uniform in [0, 1) with 24 bits; the same bits as reference.white_noise.
float white_noise(uvec3 key) {
    uint h = hash_u32(key.x + hash_u32(key.y + hash_u32(key.z)));
    return float(h >> 8u) * (1.0 / 16777216.0);
}

uint white_stream(uint seed, uint frame, uint channel) {
    return hash_u32(hash_u32(seed) + 2u * frame + channel);
}

// reference.white_offsets for pixel (x, y); seed and frame taken mod 2^32 on the CPU.
vec2 white_offset(uvec2 pixel, uint seed, uint frame) {
    return vec2(white_noise(uvec3(pixel, white_stream(seed, frame, 0u))),
                white_noise(uvec3(pixel, white_stream(seed, frame, 1u))));
}

#endif
