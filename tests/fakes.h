// Small stand-ins shared by the unit tests: a tiny policy configuration and a one-dimensional
// environment in which moving forward succeeds.
#pragma once

#include <algorithm>
#include <string>
#include <vector>

#include "core/config.h"
#include "core/env.h"

namespace dd::fakes {

/// The smallest U-Net, T_p 8, T_a 4: learns a toy in a few dozen steps.
inline PolicyConfig tiny_policy(int obs_dim = 2, int action_dim = 2) {
  PolicyConfig c;
  c.obs_dim = obs_dim;
  c.action_dim = action_dim;
  c.horizon = 8;
  c.action_steps = 4;
  c.unet = unet_preset("tiny");
  return c;
}

/// A point on a line: the action is a velocity clipped to [-1, 1]; success at x >= goal. Every
/// reset restores the time limit it was built with (runners set their own after the reset).
class LineEnv : public Env {
 public:
  explicit LineEnv(float goal = 10, int limit = 50) : goal_(goal), default_limit_(limit), limit_(limit) {}
  std::string name() const override { return "line"; }
  int obs_dim() const override { return 1; }
  int action_dim() const override { return 1; }
  int time_limit() const override { return limit_; }
  void set_time_limit(int s) override { limit_ = s; }
  double control_hz() const override { return 10; }
  void reset(uint64_t) override {
    x_ = 0;
    steps_ = 0;
    limit_ = default_limit_;
  }
  Vec observation() const override { return Vec::Constant(1, x_); }
  StepResult step(const Vec& a) override {
    x_ += std::clamp(a[0], -1.f, 1.f);
    ++steps_;
    StepResult r;
    r.success = success();
    r.done = r.success || steps_ >= limit_;
    return r;
  }
  bool success() const override { return x_ >= goal_; }
  int steps() const override { return steps_; }
  std::vector<double> save_state() const override { return {x_, double(steps_)}; }
  void restore_state(const std::vector<double>& s) override {
    x_ = static_cast<float>(s[0]);
    steps_ = static_cast<int>(s[1]);
  }

 private:
  float goal_;
  int default_limit_;
  float x_ = 0;
  int steps_ = 0, limit_;
};

}  // namespace dd::fakes
