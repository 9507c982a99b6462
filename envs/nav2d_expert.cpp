#include "envs/nav2d_expert.h"

#include <random>

#include "core/config.h"

namespace dd {

Nav2dExpert::Nav2dExpert(Mode mode, Nav2dConfig config, double p_clockwise)
    : mode_(mode), current_(mode == Mode::kMixed ? Mode::kClockwise : mode), config_(std::move(config)),
      p_clockwise_(p_clockwise) {}

std::string Nav2dExpert::name() const {
  switch (mode_) {
    case Mode::kClockwise: return "nav2d-cw";
    case Mode::kCounterClockwise: return "nav2d-ccw";
    case Mode::kMixed: return "nav2d-mixed";
  }
  return "?";
}

void Nav2dExpert::reset(uint64_t seed) {
  if (mode_ != Mode::kMixed) return;
  std::mt19937_64 rng(seed ^ 0x9e3779b97f4a7c15ull);
  current_ = std::uniform_real_distribution<double>(0, 1)(rng) < p_clockwise_ ? Mode::kClockwise : Mode::kCounterClockwise;
}

Vec2 Nav2dExpert::target(const Vec2& position, Mode mode, const Vec2& center) const {
  // Work in the obstacle's frame.
  const Vec2 p = position - center;
  const Vec2 goal = config_.goal - center;
  const Vec2 to_goal = goal - p;
  // Straight to the goal when the segment clears the obstacle with a margin.
  const double len2 = to_goal.squaredNorm();
  const double t = len2 > 0 ? std::clamp(-p.dot(to_goal) / len2, 0.0, 1.0) : 0.0;
  const double clearance = (p + t * to_goal).norm();
  if (clearance > config_.obstacle_radius + config_.agent_radius + 0.05) {
    const double d = to_goal.norm();
    return center + (d <= lookahead ? goal : Vec2(p + to_goal * (lookahead / d)));
  }
  const double r = std::max(p.norm(), 1e-6);
  const Vec2 radial = p / r;
  // Clockwise decreases the polar angle: from the start on the left it goes over the top.
  const Vec2 tangent = mode == Mode::kClockwise ? Vec2(radial.y(), -radial.x()) : Vec2(-radial.y(), radial.x());
  const Vec2 dir = (tangent + radial_gain * (orbit_radius - r) * radial).normalized();
  return center + p + lookahead * dir;
}

Vec Nav2dExpert::act(const Env& env) {
  const auto* nav = dynamic_cast<const Nav2dEnv*>(&env);
  if (!nav) throw Error("nav2d expert: it drives a nav2d env, got '" + env.name() + "'");
  const Vec2 t = target(nav->position(), current_, nav->obstacle_center());
  Vec a(2);
  a << static_cast<float>(t.x()), static_cast<float>(t.y());
  return a;
}

}  // namespace dd
