#version 330
// A texture as 8-bit file values, the same numbers as imageio.to_uint8 on its float read-back: x * 255 in
// float32, rounded half to even (NumPy's rint), clamped to [0, 255]; NaN becomes 0 (what NumPy's cast gives
// here). Integer output, so no unorm conversion can round again. Rows are written top first (file order).
//
// With PNG_ROWS defined (GL.read_png_rows), the output is the byte stream a PNG's IDAT compresses instead:
// each image row top first, as a filter byte 0 ("none") and then the row's grey (PNG_CHANNELS 1) or RGB
// (PNG_CHANNELS 3) bytes. The stream is laid out 4 bytes a texel, row after row of the target texture, so
// reading the target back gives the stream contiguous (padded with zeros past its end).
//
// With YUV420 defined (GL.read_yuv420), the outputs are a film frame's planes as H.264/VP9 take them: BT.601
// limited range ("tv") 4:2:0, the conversion swscale applies to rgb24 -> yuv420p by default. The 8-bit RGB
// values above (grey repeated for YUV420_CHANNELS 1) give Y = 16 + 219/255 (0.299 R + 0.587 G + 0.114 B),
// Cb = 128 + 224/255 (B - Y') / 1.772, Cr = 128 + 224/255 (R - Y') / 1.402 (Y' the unscaled luma), chroma
// from the mean of each 2x2 block's RGB (centre siting as swscale's; swscale filters rows [1 3 3 1] / 8),
// each rounded half to even; past
// the source's last column/row the last one is repeated (even sizes). A fragment covers 4 x 2 pixels, each
// fetched once: 4 bytes of an even Y row (location 0), 4 of the odd row below (1), 2 of U (2), 2 of V (3).
#if defined FRAGMENT_SHADER
uniform sampler2D t_src;
uniform int u_height;
layout(location = 0) out uvec4 o_bytes;

vec4 bytes_of(vec4 x) {
    vec4 v = clamp(roundEven(x * 255.0), 0.0, 255.0);
    return mix(v, vec4(0.0), isnan(x));
}

#if defined YUV420
uniform ivec2 u_src;  // the source texture's size
layout(location = 1) out uvec4 o_odd;
layout(location = 2) out uvec2 o_u;
layout(location = 3) out uvec2 o_v;

vec3 rgb8(int x, int y) {  // the 8-bit RGB of pixel (x, y), rows top first, clamped to the source
    vec3 v = bytes_of(texelFetch(t_src, ivec2(min(x, u_src.x - 1), u_src.y - 1 - min(y, u_src.y - 1)), 0)).rgb;
#if YUV420_CHANNELS == 1
    v = v.rrr;
#endif
    return v;
}

const vec3 K_Y = vec3(0.299, 0.587, 0.114) * (219.0 / 255.0);
const vec3 K_CB = vec3(-0.299, -0.587, 0.886) * (224.0 / 255.0 / 1.772);
const vec3 K_CR = vec3(0.701, -0.587, -0.114) * (224.0 / 255.0 / 1.402);

uvec4 luma(vec3 a, vec3 b, vec3 c, vec3 d) {
    vec4 y = vec4(16.0) + vec4(dot(K_Y, a), dot(K_Y, b), dot(K_Y, c), dot(K_Y, d));
    return uvec4(clamp(roundEven(y), 0.0, 255.0));
}

uvec2 chroma(vec3 k, vec3 m0, vec3 m1) {
    return uvec2(clamp(roundEven(vec2(128.0) + vec2(dot(k, m0), dot(k, m1))), 0.0, 255.0));
}

uniform ivec2 u_offset;  // the fragment of the whole frame at the targets' (0, 0): a footprint's block

void main() {
    ivec2 p = (ivec2(gl_FragCoord.xy) + u_offset) * ivec2(4, 2);
    vec3 a0 = rgb8(p.x, p.y), a1 = rgb8(p.x + 1, p.y), a2 = rgb8(p.x + 2, p.y), a3 = rgb8(p.x + 3, p.y);
    vec3 b0 = rgb8(p.x, p.y + 1), b1 = rgb8(p.x + 1, p.y + 1), b2 = rgb8(p.x + 2, p.y + 1),
         b3 = rgb8(p.x + 3, p.y + 1);
    o_bytes = luma(a0, a1, a2, a3);
    o_odd = luma(b0, b1, b2, b3);
    vec3 m0 = (a0 + a1 + b0 + b1) * 0.25, m1 = (a2 + a3 + b2 + b3) * 0.25;
    o_u = chroma(K_CB, m0, m1);
    o_v = chroma(K_CR, m0, m1);
}
#elif defined PNG_WIDE
// The image rows, top first, without filter bytes: 16 bytes a fragment into an RGBA32UI target of
// PNG_CHANNELS * width / 16 texels a row (used where that is whole: GL.read_png_rows adds the filter bytes
// on the host, one contiguous copy a row). Fewer, wider fragments: each pixel is fetched 1.125 times (RGB)
// or once (grey), against 1.5 times in twice the fragments of the 4-byte stream layout below.
uniform int u_width;  // the source texture's width

vec4 pixel(int px, int row) {  // the 8-bit values of pixel px of image row `row` (rows counted top first)
    return bytes_of(texelFetch(t_src, ivec2(min(px, u_width - 1), u_height - 1 - row), 0));
}

uniform ivec2 u_offset;  // the fragment of the whole layout at the target's (0, 0): a footprint's block

uint pack4(vec4 b) { uvec4 u = uvec4(b); return u.x | (u.y << 8) | (u.z << 16) | (u.w << 24); }

void main() {
    ivec2 f = ivec2(gl_FragCoord.xy) + u_offset;
    int row = f.y;
#if PNG_CHANNELS == 1
    int p = 16 * f.x;
    vec4 q[4];
    for (int k = 0; k < 4; ++k)
        q[k] = vec4(pixel(p + 4 * k, row).r, pixel(p + 4 * k + 1, row).r, pixel(p + 4 * k + 2, row).r,
                    pixel(p + 4 * k + 3, row).r);
    o_bytes = uvec4(pack4(q[0]), pack4(q[1]), pack4(q[2]), pack4(q[3]));
#else
    // bytes 16 f.x .. 16 f.x + 15 of the row lie in pixels p .. p + 5 from byte `phase` of pixel p on
    int b = 16 * f.x;
    int p = b / 3;
    int phase = b - 3 * p;
    vec3 c0 = pixel(p, row).rgb, c1 = pixel(p + 1, row).rgb, c2 = pixel(p + 2, row).rgb,
         c3 = pixel(p + 3, row).rgb, c4 = pixel(p + 4, row).rgb, c5 = pixel(p + 5, row).rgb;
    // the 18 bytes of the six pixels, four at a time (the last two padded)
    vec4 b0 = vec4(c0, c1.r), b1 = vec4(c1.gb, c2.rg), b2 = vec4(c2.b, c3), b3 = vec4(c4, c5.r),
         b4 = vec4(c5.gb, 0.0, 0.0);
    // shifted by `phase` bytes, branch-free (llvmpipe runs both sides of a branch its lanes disagree on)
    bool one = phase == 1, two = phase == 2;
    vec4 o0 = two ? vec4(b0.zw, b1.xy) : (one ? vec4(b0.yzw, b1.x) : b0);
    vec4 o1 = two ? vec4(b1.zw, b2.xy) : (one ? vec4(b1.yzw, b2.x) : b1);
    vec4 o2 = two ? vec4(b2.zw, b3.xy) : (one ? vec4(b2.yzw, b3.x) : b2);
    vec4 o3 = two ? vec4(b3.zw, b4.xy) : (one ? vec4(b3.yzw, b4.x) : b3);
    o_bytes = uvec4(pack4(o0), pack4(o1), pack4(o2), pack4(o3));
#endif
}
#elif defined PNG_ROWS
uniform int u_width;        // the source texture's width
uniform int u_target_width; // texels in a row of the target
uniform int u_total;        // bytes in the stream: u_height * (1 + PNG_CHANNELS * u_width)

vec4 pixel(int px, int row) {  // the 8-bit values of pixel px of image row `row` (rows counted top first)
    return bytes_of(texelFetch(t_src, ivec2(px, u_height - 1 - min(row, u_height - 1)), 0));
}

// Branch-free on purpose: llvmpipe runs both sides of a branch its SIMD lanes disagree on.
void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    int stride = 1 + PNG_CHANNELS * u_width;  // bytes of one image row in the stream
    int b0 = 4 * (p.y * u_target_width + p.x);
    // the image row of the first byte: a float quotient (integer division by a uniform is slow on the CPU)
    // corrected to the exact one
    int row = int(float(b0) / float(stride));
    int j0 = b0 - row * stride;  // place of the first byte in its row; 0 is the filter byte
    row += j0 >= stride ? 1 : (j0 < 0 ? -1 : 0);
    j0 = b0 - row * stride;
    int left = stride - j0;  // bytes of this row from the first one on: 1..3 means the next row starts here
#if PNG_CHANNELS == 1
    ivec4 j = ivec4(j0) + ivec4(0, 1, 2, 3);
    ivec4 next = ivec4(greaterThanEqual(j, ivec4(stride)));
    j -= next * stride;
    ivec4 r = ivec4(row) + next;
    ivec4 px = max(j - 1, 0);
    vec4 v = vec4(pixel(px.x, r.x).r, pixel(px.y, r.y).r, pixel(px.z, r.z).r, pixel(px.w, r.w).r);
    v = mix(v, vec4(0.0), equal(j, ivec4(0)));  // filter bytes
#else
    // RGB: four bytes touch two pixels at most. Inside a row they are pixel px from channel `phase` on and
    // pixel px + 1; at a row's start the filter byte and pixel 0; across a row's end the last pixel, the
    // next row's filter byte and its pixel 0.
    int q = max(j0 - 1, 0);
    int px = q / 3;
    int phase = q - px * 3;
    bool start = j0 == 0;
    bool across = left <= 3;
    ivec2 ca = across ? ivec2(u_width - 1, row) : ivec2(px, row);
    ivec2 cb = across ? ivec2(0, row + 1) : ivec2(min(px + 1, u_width - 1), row);
    vec4 a = pixel(ca.x, ca.y);
    vec4 b = pixel(cb.x, cb.y);
    vec4 inside = phase == 0 ? vec4(a.rgb, b.r) : (phase == 1 ? vec4(a.gb, b.rg) : vec4(a.b, b.rgb));
    vec4 at_end = left == 1 ? vec4(a.b, 0.0, b.rg) : (left == 2 ? vec4(a.gb, 0.0, b.r) : vec4(a.rgb, 0.0));
    vec4 v = start ? vec4(0.0, a.rgb) : (across ? at_end : inside);
#endif
    // past the end of the stream: zeros
    v = mix(v, vec4(0.0), greaterThanEqual(ivec4(b0) + ivec4(0, 1, 2, 3), ivec4(u_total)));
    o_bytes = uvec4(v);
}
#else
void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    o_bytes = uvec4(bytes_of(texelFetch(t_src, ivec2(p.x, u_height - 1 - p.y), 0)));
}
#endif
#endif
