// Shared helpers for image-space passes; pull in with an include directive.
// Texel centre of pixel `px` for a texture of size `size`.
vec2 texel_uv(ivec2 px, vec2 size) { return (vec2(px) + 0.5) / size; }
// Rec. 709 luminance.
float luminance(vec3 c) { return dot(c, vec3(0.2126, 0.7152, 0.0722)); }
