// The pick-and-place expert behind stacking and plugging: grasp an object from above, carry it over
// its target, lower it into place, let go and back off. Transit moves are planned with RRT-Connect
// around the task's obstacles (planner.h); the phase (reach, close, carry, lower, release, retreat) is
// read from the state at every step, so the expert can take over from any reachable mid-episode
// state, and it retries a missed grasp. The final approach is aligned on the object's own pose, so a
// grasp that is a few millimetres off still places it precisely.
#pragma once

#include <cstdint>
#include <vector>

#include "core/env.h"
#include "envs/mujoco/arm_env.h"
#include "envs/mujoco/planner.h"

namespace dd::mj {

/// A TCP rotation pointing down with the fingers' closing axis at `yaw` [rad] from world y.
Eigen::Matrix3d tool_down(double yaw);
/// The yaw of a TCP rotation about the world z axis.
double tool_yaw(const Eigen::Matrix3d& R);

/// What the expert needs to know about the task in the current state.
struct PickPlaceState {
  Eigen::Vector3d object{0, 0, 0};  // the object's origin (the grasp point)
  double object_yaw = 0;            // its yaw (grasped at the nearest quarter turn)
  double width = 0.04;              // its width between the fingers [m]
  Eigen::Vector3d place{0, 0, 0};   // where the object's origin must end up
  double place_yaw = 0;             // the yaw the object must have in place (with align_yaw)
  bool align_yaw = false;           // turn the object to place_yaw (a quarter-turn symmetry) while carrying
  double approach = 0.08;           // height above `place` from which it is lowered [m]
  double lower_speed = 0.006;       // lowering speed [m per step]
  double lift = 0.06;               // after grasping, rise straight up until this high above `place` [m]
  bool plumb_lift = false;          // lift without following the TCP's drift or turning (out of a snug hole)
  bool placed = false;              // the object is in place (time to let go)
  std::vector<Box3> obstacles;      // to plan around (the carried object's size is added)
  double hang = 0.03;               // how far the carried object hangs below the TCP [m]
};

class PickPlaceExpert : public Expert {
 public:
  void reset(uint64_t seed) override;
  Vec act(const Env& env) override;

  double speed = 0.025;  // max TCP travel per step in transit [m]
  double slow = 0.012;   // near the objects [m]
  /// Per-episode detours [m]: with detour > 0 the expert first goes to a point 0.5-1 x detour beside
  /// the pre-grasp point and beside the point over the target (a seeded random direction each), then
  /// corrects to the exact point. Demonstrations then show the corrections a learned policy needs
  /// when it arrives a little off; a straight expert never leaves the one line to each point.
  double detour = 0;

 protected:
  virtual PickPlaceState read(const ArmEnv& env) const = 0;

 private:
  Vec command(const Eigen::Vector3d& p, const Eigen::Matrix3d& R, double grip);
  Eigen::Vector3d follow(const ArmEnv& env, const PickPlaceState& s, const Eigen::Vector3d& goal, double max_step, bool holding);

  uint64_t seed_ = 0;
  int closing_ = 0;
  bool have_target_ = false, lowering_ = false;
  Eigen::Vector3d target_{0, 0, 0};
  std::vector<Eigen::Vector3d> path_;
  Eigen::Vector3d path_goal_{1e9, 0, 0};
  size_t path_i_ = 0;
  double yaw_ = 0;
  bool have_yaw_ = false;
  Eigen::Vector2d pre_detour_{0, 0}, hover_detour_{0, 0};  // this episode's offsets
  bool pre_detoured_ = true, hover_detoured_ = true;       // done (or not wanted)
  /// `goal`, or the detour point beside it until the TCP has been there (or started close to it).
  Eigen::Vector3d via_detour(const Eigen::Vector3d& tcp, const Eigen::Vector3d& goal, const Eigen::Vector2d& offset, bool& done);
};

}  // namespace dd::mj
