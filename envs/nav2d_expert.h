// The scripted expert of the 2-D toy: a vector field that circles the obstacle clockwise (over the top)
// or counter-clockwise (underneath) at a fixed orbit radius and heads straight for the goal once the
// way is clear. It is a feedback law, so it succeeds from any free state, which lets it take over in the
// middle of an episode.
#pragma once

#include "envs/nav2d.h"

namespace dd {

class Nav2dExpert : public Expert {
 public:
  enum class Mode { kClockwise, kCounterClockwise, kMixed };

  /// kMixed picks clockwise with probability `p_clockwise` at every reset.
  explicit Nav2dExpert(Mode mode = Mode::kMixed, Nav2dConfig config = {}, double p_clockwise = 0.5);

  std::string name() const override;
  void reset(uint64_t seed) override;
  /// The target position for the env's agent (the env must be a Nav2dEnv).
  Vec act(const Env& env) override;

  /// The mode of the current episode (never kMixed after reset).
  Mode episode_mode() const { return current_; }
  /// The target the expert commands at position p in a given (non-mixed) mode, with the obstacle
  /// centred at `center`.
  Vec2 target(const Vec2& p, Mode mode, const Vec2& center = Vec2::Zero()) const;

  double orbit_radius = 0.65;  // radius of the path around the obstacle [m]
  double lookahead = 0.15;     // distance from the agent to the commanded target [m]
  double radial_gain = 4.0;    // pull towards the orbit radius [1/m]

 private:
  Mode mode_, current_;
  Nav2dConfig config_;
  double p_clockwise_;
};

}  // namespace dd
