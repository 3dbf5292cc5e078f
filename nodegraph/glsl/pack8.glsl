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

void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    int stride = 1 + PNG_CHANNELS * u_width;  // bytes of one image row in the stream
    int b0 = 4 * (p.y * u_target_width + p.x);
    // the image row of the first byte: a float quotient (integer division by a uniform is slow on the CPU)
    // corrected to the exact one
    int row = int(float(b0) / float(stride));
    int j0 = b0 - row * stride;
    if (j0 < 0) { row -= 1; j0 += stride; }
    if (j0 >= stride) { row += 1; j0 -= stride; }
    // the four bytes: their place in a row (0 is the filter byte) and their row (a row holds 4 bytes or more,
    // so they reach at most into the next one)
    ivec4 j = ivec4(j0) + ivec4(0, 1, 2, 3);
    ivec4 next = ivec4(greaterThanEqual(j, ivec4(stride)));
    j -= next * stride;
    ivec4 r = ivec4(row) + next;
    ivec4 q = max(j - 1, 0);
    ivec4 px = q / PNG_CHANNELS;
    ivec4 ch = q - px * PNG_CHANNELS;
#if PNG_CHANNELS == 1
    // grey: one pixel a byte
    vec4 v = vec4(bytes_of(texelFetch(t_src, ivec2(px.x, u_height - 1 - min(r.x, u_height - 1)), 0)).x,
                  bytes_of(texelFetch(t_src, ivec2(px.y, u_height - 1 - min(r.y, u_height - 1)), 0)).x,
                  bytes_of(texelFetch(t_src, ivec2(px.z, u_height - 1 - min(r.z, u_height - 1)), 0)).x,
                  bytes_of(texelFetch(t_src, ivec2(px.w, u_height - 1 - min(r.w, u_height - 1)), 0)).x);
#else
    // RGB: four bytes touch at most two pixels, the first data byte's and the last one's
    int fa = j.x == 0 ? 1 : 0;  // the first data byte (byte 0, or byte 1 after a filter byte)
    int fb = j.w == 0 ? 2 : 3;  // the last data byte
    ivec2 a = ivec2(px[fa], min(r[fa], u_height - 1));
    ivec2 bb = ivec2(px[fb], min(r[fb], u_height - 1));
    vec4 va = bytes_of(texelFetch(t_src, ivec2(a.x, u_height - 1 - a.y), 0));
    vec4 vb = bytes_of(texelFetch(t_src, ivec2(bb.x, u_height - 1 - bb.y), 0));
    vec4 v;
    for (int k = 0; k < 4; k++) {
        bool from_a = px[k] == a.x && r[k] == a.y;
        v[k] = from_a ? va[ch[k]] : vb[ch[k]];
    }
#endif
    // filter bytes are 0, and so is everything past the end of the stream
    bvec4 is_filter = equal(j, ivec4(0));
    bvec4 past = greaterThanEqual(ivec4(b0) + ivec4(0, 1, 2, 3), ivec4(u_total));
    o_bytes = uvec4(mix(v, vec4(0.0), bvec4(ivec4(is_filter) | ivec4(past))));
}
#else
void main() {
    ivec2 p = ivec2(gl_FragCoord.xy);
    o_bytes = uvec4(bytes_of(texelFetch(t_src, ivec2(p.x, u_height - 1 - p.y), 0)));
}
#endif
#endif
