// Shapes with anti-aliased edges computed from the local coordinate:
//   mode 0  flat fill (walls, floor)
//   mode 1  disc: the unit disc, with an optional darker rim (agent, obstacle, goal, markers)
//   mode 2  stroke: a line whose edges fade across its width (paths, chunks)
#version 130

uniform int u_mode;
uniform float u_rim;  // disc: rim width as a fraction of the radius (0: none)

in vec2 v_local;
in vec4 v_color;

out vec4 frag_color;

void main() {
  vec4 c = v_color;
  if (u_mode == 1) {
    float r = length(v_local);
    float w = max(fwidth(r), 1e-4);
    c.a *= 1.0 - smoothstep(1.0 - w, 1.0, r);
    if (u_rim > 0.0) c.rgb *= mix(1.0, 0.55, smoothstep(1.0 - u_rim - w, 1.0 - u_rim, r));
  } else if (u_mode == 2) {
    float d = abs(v_local.y);
    float w = max(fwidth(d), 1e-4);
    c.a *= 1.0 - smoothstep(1.0 - w, 1.0, d);
  }
  if (c.a <= 0.0) discard;
  frag_color = c;
}
