#version 330
// Rest-pose positions of posed (skinned or morphed) meshes (docs/animation.md): the posed geometry is drawn
// as the G-buffer pass draws it, enlarged along its smooth normals, and each fragment writes the rest-pose
// position of the same surface point, enlarged along the rest pose's smooth normals, so object-space noise
// read at it follows the deforming surface.
#if defined VERTEX_SHADER
in vec3 in_pos;
in vec3 in_smooth;
in vec3 in_rest;         // the vertex in the rest pose (object space, relative to the rest mesh's origin)
in vec3 in_rest_smooth;  // the rest pose's direction of enlargement
uniform mat4 u_model;
uniform mat4 u_view;
uniform mat4 u_proj;
uniform float u_enlarge;       // posed, object-space distance along in_smooth
uniform float u_rest_enlarge;  // the same in the rest pose's units
out vec3 v_rest;
void main() {
    vec3 p = in_pos + in_smooth * u_enlarge;
    v_rest = in_rest + in_rest_smooth * u_rest_enlarge;
    gl_Position = u_proj * (u_view * u_model * vec4(p, 1.0));
}
#elif defined FRAGMENT_SHADER
in vec3 v_rest;
out vec4 o_position;
void main() {
    o_position = vec4(v_rest, 1.0);
}
#endif
