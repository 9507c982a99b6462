// The 2-D scene: every shape is a quad or triangle in world coordinates (metres) with a local
// coordinate that the fragment shader turns into a smooth edge.
#version 130

uniform vec4 u_view;  // world -> clip: clip = (world - u_view.xy) * u_view.zw

in vec2 a_pos;
in vec2 a_local;  // disc: position in the unit disc; stroke: (along, across in [-1, 1])
in vec4 a_color;

out vec2 v_local;
out vec4 v_color;

void main() {
  v_local = a_local;
  v_color = a_color;
  gl_Position = vec4((a_pos - u_view.xy) * u_view.zw, 0.0, 1.0);
}
