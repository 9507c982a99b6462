// Stacking: a red cube and a green cube lie at random places on the table; the arm must put the red
// cube on the green one and let go. T_L = 250 steps at 20 Hz.
//   observation (37): joints (7), TCP position (3), TCP 6-D rotation (6), gripper opening (1),
//                     red cube position (3) and quaternion (4), green cube position (3) and quaternion (4),
//                     red minus TCP (3) and green minus red (3): the grasp and placement errors
//                     directly, as robomimic's gripper-to-object features, rather than as small
//                     differences of large normalised positions
//   action      (10): TCP position (3), TCP 6-D rotation (6), gripper (0 open .. 1 closed)
//   success: the red cube rests on the green one (centres within 2 cm horizontally, its bottom on the
//            green top within 1 cm) and the gripper is open (>= 6 cm) above it
#pragma once

#include "envs/mujoco/arm_env.h"

namespace dd::mj {

struct StackConfig {
  double red_half = 0.02;     // cube half-sizes [m]
  double green_half = 0.025;
  Eigen::Vector2d x_range{0.40, 0.62}, y_range{-0.20, 0.20};  // where cubes are placed [m]
  double min_separation = 0.12;
  int time_limit = 250;
  int camera_size = 96;       // offscreen buffer for camera observations
};

class StackEnv : public ArmEnv {
 public:
  explicit StackEnv(StackConfig config = {});
  int obs_dim() const override { return 37; }
  void reset(uint64_t seed) override;
  Vec observation() const override;

  const StackConfig& config() const { return config_; }
  Eigen::Vector3d red_pos() const { return free_pos(model(), data(), red_); }
  Eigen::Vector3d green_pos() const { return free_pos(model(), data(), green_); }
  double red_yaw() const;
  double green_yaw() const;
  /// True when the red cube rests on the green one (whatever the gripper does).
  bool red_on_green() const;
  /// success; "on green, not released"; "held" (lifted in the gripper); "leaning on green" or
  /// "beside green" (dropped within 6 cm); "moved" (elsewhere, off its start); "not grasped".
  std::string outcome() const override;

 protected:
  bool check_success() const override;

 private:
  StackConfig config_;
  int red_ = -1, green_ = -1;
  Eigen::Vector3d red_start_{0, 0, 0};
};

/// The scene's MJCF (for tools and tests).
std::string stack_xml(const StackConfig& config);

}  // namespace dd::mj
