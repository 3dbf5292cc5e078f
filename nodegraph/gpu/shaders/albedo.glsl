// The value of a surface colour, as pencil tone takes it (pencil_shade and contour `albedo_weight`): CIE
// lightness L* (0..100) of a display (sRGB-encoded) colour: Rec. 709 luminance of its linear values, then
// L* = 116 Y^(1/3) - 16 (903.3 Y in the dark range). nodes/_shared/pencil.py albedo_lightness is the
// same in float64.
float albedo_lightness(vec3 display) {
    vec3 c = clamp(display, 0.0, 1.0);
    c = mix(c / 12.92, pow((c + 0.055) / 1.055, vec3(2.4)), step(vec3(0.04045), c));
    float y = dot(c, vec3(0.2126, 0.7152, 0.0722));
    return y > 0.008856 ? 116.0 * pow(y, 1.0 / 3.0) - 16.0 : 903.3 * y;
}

// The factor on brightness: (L* / ref)^weight, 1 within 0.1 % of the reference (so the reference colour is
// bit-identical to no albedo at all).
float albedo_factor(vec3 display, float ref, float weight) {
    float lstar = albedo_lightness(display);
    return abs(lstar - ref) > 1e-3 * ref ? pow(max(lstar, 0.1) / ref, weight) : 1.0;
}
