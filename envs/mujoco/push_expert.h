// The pushing experts: a greedy quasi-static pusher. At each stroke it picks the contact point on the
// T's outline whose push (straight in along the inward normal) best produces the wanted motion:
// a translation towards the goal and a rotation in the expert's own sense (clockwise or
// counter-clockwise) until the yaw is close, then whichever way is shorter. It then goes round to the
// contact's outside (lifting the stick over the block when the way is blocked), pushes a stroke, and
// chooses again. The mixed expert picks one of the two senses per episode.
#pragma once

#include <cstdint>
#include <random>

#include "core/env.h"
#include "envs/mujoco/push.h"

namespace dd::mj {

class PushExpert : public Expert {
 public:
  /// kMixed draws the sense from the episode's seed; kAlternate turns clockwise on even episode seeds
  /// and counter-clockwise on odd ones, so consecutive episodes alternate (the two-expert data sets).
  enum class Mode { kClockwise, kCounterClockwise, kMixed, kAlternate };
  explicit PushExpert(Mode mode = Mode::kMixed) : mode_(mode), current_(mode) {}

  std::string name() const override;
  void reset(uint64_t seed) override;
  Vec act(const Env& env) override;
  /// The sense of this episode (never kMixed or kAlternate after reset).
  Mode episode_mode() const { return current_; }

  double speed = 0.035;       // stick travel per step when repositioning [m]
  double push_speed = 0.015;  // per step while pushing [m]
  int stroke = 12;            // steps per push stroke

 private:
  void choose_contact(const PushEnv& env);

  Mode mode_, current_;
  enum class Phase { kChoose, kApproach, kPush } phase_ = Phase::kChoose;
  Eigen::Vector2d contact_{0, 0}, normal_{0, 0};  // block frame
  int pushed_ = 0;
  double stroke_turn_ = 0;  // the yaw error when the stroke began
  Eigen::Vector3d target_{0, 0, 0};
  bool have_target_ = false;
};

}  // namespace dd::mj
