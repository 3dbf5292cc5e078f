#version 330
// The engine's full-screen triangle. v_uv runs over [0,1]^2 across the viewport (row 0 = bottom).
#if defined VERTEX_SHADER
out vec2 v_uv;
void main() {
    vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2);
    v_uv = p;
    gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
#endif
