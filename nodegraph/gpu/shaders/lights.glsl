// Punctual lights (KHR_lights_punctual) in view space: irradiance at a surface point, as
// nodegraph/scene/lights.py defines it (`irradiance`; uniforms from `view_uniforms`). Include it where the
// define LIGHTS (the number of lights, 1..8) is set; without it a shader keeps its one scene light.
uniform vec4 u_light_pos[LIGHTS];    // xyz: position, or unit direction towards a directional light; w: 1 | 0
uniform vec4 u_light_dir[LIGHTS];    // xyz: unit direction the light shines along; w: range (0: infinite)
uniform vec3 u_light_color[LIGHTS];  // colour x intensity x the scene's exposure
uniform vec2 u_light_cone[LIGHTS];   // spot factor clamp(cos * x + y, 0, 1)^2; (0, 1) for other lights

// E(p, n): linear RGB irradiance times exposure at view-space point p with unit normal n
vec3 light_irradiance(vec3 p, vec3 n) {
    vec3 e = vec3(0.0);
    for (int i = 0; i < LIGHTS; ++i) {
        vec4 lp = u_light_pos[i];
        vec3 l = lp.xyz;
        float amount = 1.0;
        if (lp.w > 0.5) {
            vec3 delta = lp.xyz - p;
            float d2 = dot(delta, delta);
            float d = sqrt(d2);
            l = d > 0.0 ? delta / d : vec3(0.0);
            amount = d2 > 0.0 ? 1.0 / d2 : 0.0;
            float range = u_light_dir[i].w;
            if (range > 0.0) {
                float r = d / range;
                amount *= clamp(1.0 - r * r * r * r, 0.0, 1.0);
            }
            float s = clamp(-dot(l, u_light_dir[i].xyz) * u_light_cone[i].x + u_light_cone[i].y, 0.0, 1.0);
            amount *= s * s;
        }
        e += u_light_color[i] * (amount * max(dot(n, l), 0.0));
    }
    return e;
}

// The brightness the tone nodes read: Rec. 709 luminance of the irradiance
float light_brightness(vec3 p, vec3 n) { return dot(light_irradiance(p, n), vec3(0.2126, 0.7152, 0.0722)); }
