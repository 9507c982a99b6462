// The common part of the arm tasks: a MuJoCo model with the Panda arm, the 20 Hz control step
// (IK or joint deltas -> servo targets -> 25 physics steps with gravity compensation), failure
// handling (non-finite actions, unstable simulation), state save/restore and determinism.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/env.h"
#include "envs/mujoco/panda.h"

namespace dd::mj {

/// How actions drive the arm.
enum class ArmControl {
  kEndEffectorPose,  // absolute TCP pose: position (3, kept in x 0.15..0.85, y -0.5..0.5, z 0.005..0.6 m),
                     // 6-D rotation (6), gripper 0..1 (1)
  kJointDelta        // relative joint positions (7) [rad per step], clipped to +-max_joint_step
};

class ArmEnv : public Env {
 public:
  ArmEnv(std::string name, const std::string& xml, Tool tool, ArmControl control, int time_limit);
  ~ArmEnv() override;

  std::string name() const override { return name_; }
  int time_limit() const override { return limit_; }
  void set_time_limit(int steps) override { limit_ = steps; }
  double control_hz() const override { return 20.0; }
  int action_dim() const override { return control_ == ArmControl::kEndEffectorPose ? 10 : 7; }
  StepResult step(const Vec& action) override;
  bool success() const override { return success_; }
  int steps() const override { return steps_; }
  std::vector<double> save_state() const override;
  void restore_state(const std::vector<double>& state) override;
  /// A TCP target the operator moves (jog in the view's ground plane, lift, or a dragged point) with
  /// the tool pointing down at the yaw it had when the takeover began, and a gripper to toggle
  /// (envs/mujoco/arm_teleoperation.cpp).
  std::unique_ptr<Teleoperation> teleoperation() const override;
  /// The model and data, for MuJoCo's renderer; under end-effector control a chunk's rows start with
  /// TCP targets, shown as points.
  std::optional<PhysicsScene> physics() const override { return PhysicsScene{model_.get(), data_.get()}; }
  std::vector<Eigen::Vector3d> action_points(const Mat& chunk) const override;

  const mjModel* model() const { return model_.get(); }
  const mjData* data() const { return data_.get(); }
  mjData* mutable_data() { return data_.get(); }
  const PandaArm& arm() const { return arm_; }
  ArmControl control() const { return control_; }
  /// The arm's part of the observation: joints (7), TCP position (3), TCP 6-D rotation (6) and, with
  /// the gripper, the opening (1).
  void arm_observation(Vec& out, int& k) const;

  /// Joint positions that bring the TCP to (p, R) from the current posture (for experts and the
  /// operator; does not change the state).
  Vec7 ik_targets(const Eigen::Vector3d& p, const Eigen::Matrix3d& R) const;

  double max_joint_step = 0.05;  // kJointDelta: rad per control step

 protected:
  /// Starts an episode: home posture, then the task places its objects (called by reset).
  void reset_arm();
  /// Task success in the current state.
  virtual bool check_success() const = 0;
  /// Physics steps per control step.
  static constexpr int kSubsteps = 25;

  std::string name_;
  ModelPtr model_;
  DataPtr data_, scratch_;
  PandaArm arm_;
  ArmControl control_;
  int default_limit_, limit_, steps_ = 0;
  bool success_ = false, failed_ = false;
};

}  // namespace dd::mj
