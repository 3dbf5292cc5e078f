// A glTF surface (nodegraph/scene/meshes.py Surface), shared by the G-buffer pass and the motion pass (included
// once, before their stage sections, where SURFACE is defined). The vertex stage passes on the texture
// coordinates through KHR_texture_transform's matrix (its first two rows) and the vertex colour (surface_pass);
// the fragment stage's surface_base() is baseColorFactor x vertex colour (VCOLOR) x base colour texture
// (TEXTURE), in linear RGBA, MIRRORED_REPEAT folded per axis; a MASK cut-out compares its alpha with u_cutoff.
#if defined VERTEX_SHADER
in vec2 in_uv;
in vec4 in_vcolor;
uniform vec3 u_uv_row0;
uniform vec3 u_uv_row1;
out vec2 v_uv;
out vec4 v_vcolor;

void surface_pass() {
    v_uv = vec2(dot(u_uv_row0, vec3(in_uv, 1.0)), dot(u_uv_row1, vec3(in_uv, 1.0)));
    v_vcolor = in_vcolor;
}
#elif defined FRAGMENT_SHADER
in vec2 v_uv;
in vec4 v_vcolor;
uniform vec4 u_factor;       // baseColorFactor, linear RGBA
uniform sampler2D t_base;    // the base colour texture, stored sRGB: it reads (and filters) linear
uniform vec2 u_mirror;       // 1 where the sampler's wrap mode is MIRRORED_REPEAT (s, t)
uniform float u_cutoff;      // alphaCutoff (MASK)

vec4 surface_base() {
    vec4 c = u_factor;
#if VCOLOR
    c *= v_vcolor;
#endif
#if TEXTURE
    vec2 uv = mix(v_uv, 1.0 - abs(mod(v_uv, 2.0) - 1.0), u_mirror);
    c *= textureGrad(t_base, uv, dFdx(v_uv), dFdy(v_uv));
#endif
    return c;
}
#endif
