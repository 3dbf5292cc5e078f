#version 330
// A texture as 8-bit file values, the same numbers as imageio.to_uint8 on its float read-back: x * 255 in
// float32, rounded half to even (NumPy's rint), clamped to [0, 255]; NaN becomes 0 (what NumPy's cast gives
// here). Integer output, so no unorm conversion can round again. Rows are written top first (file order).
//
// With PNG_ROWS defined (GL.read_png_rows), the output is the byte stream a PNG's IDAT compresses instead:
// each image row top first, as a filter byte 0 ("none") and then the row's grey (PNG_CHANNELS 1) or RGB
// (PNG_CHANNELS 3) bytes. The stream is laid out 4 bytes a texel, row after row of the target texture, so
// reading the target back gives the stream contiguous (padded with zeros past its end).
#if defined FRAGMENT_SHADER
uniform sampler2D t_src;
uniform int u_height;
layout(location = 0) out uvec4 o_bytes;

vec4 bytes_of(vec4 x) {
    vec4 v = clamp(roundEven(x * 255.0), 0.0, 255.0);
    return mix(v, vec4(0.0), isnan(x));
}

#if defined PNG_ROWS
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
