// The stacking expert: grasp the red cube from above, carry it over the green one and let go. Transit
// moves are planned with RRT-Connect around the other cube (planner.h); the phase (reach, close,
// carry, place, release, retreat) is read from the state at every step, so the expert can take over
// from any reachable mid-episode state and retries a missed grasp.
#pragma once

#include <cstdint>
#include <vector>

#include "core/env.h"
#include "envs/mujoco/stack.h"

namespace dd::mj {

/// A TCP rotation pointing down with the fingers' closing axis at `yaw` [rad] from world y.
Eigen::Matrix3d tool_down(double yaw);
/// The yaw of a TCP rotation about the world z axis.
double tool_yaw(const Eigen::Matrix3d& R);

class StackExpert : public Expert {
 public:
  std::string name() const override { return "stack_planner"; }
  void reset(uint64_t seed) override;
  Vec act(const Env& env) override;

  double speed = 0.025;      // max TCP travel per step in transit [m]
  double slow = 0.012;       // near the cubes [m]

 private:
  Vec command(const Eigen::Vector3d& p, const Eigen::Matrix3d& R, double grip);
  Eigen::Vector3d follow(const StackEnv& env, const Eigen::Vector3d& goal, double max_step, bool holding);

  uint64_t seed_ = 0;
  int closing_ = 0, opening_ = 0;
  bool have_target_ = false;
  Eigen::Vector3d target_{0, 0, 0};
  std::vector<Eigen::Vector3d> path_;
  Eigen::Vector3d path_goal_{1e9, 0, 0};
  size_t path_i_ = 0;
  double yaw_ = 0;
  bool have_yaw_ = false;
};

}  // namespace dd::mj
