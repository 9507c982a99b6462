// The diffusion-loss field as a heat map behind the scene: a single-channel texture of log-losses
// normalised to [0, 1], coloured with a perceptual (magma-like) ramp.
#version 130

uniform sampler2D u_field;
uniform float u_alpha;

in vec2 v_local;  // texture coordinate
in vec4 v_color;

out vec4 frag_color;

vec3 ramp(float t) {
  vec3 c0 = vec3(0.02, 0.01, 0.09);
  vec3 c1 = vec3(0.45, 0.12, 0.50);
  vec3 c2 = vec3(0.93, 0.35, 0.33);
  vec3 c3 = vec3(0.99, 0.91, 0.65);
  if (t < 0.33) return mix(c0, c1, t / 0.33);
  if (t < 0.66) return mix(c1, c2, (t - 0.33) / 0.33);
  return mix(c2, c3, (t - 0.66) / 0.34);
}

void main() {
  float t = clamp(texture(u_field, v_local).r, 0.0, 1.0);
  frag_color = vec4(ramp(t), u_alpha);
}
