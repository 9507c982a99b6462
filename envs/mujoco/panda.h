// A 7-DoF arm with the Franka Emika Panda's published kinematics (modified Denavit-Hartenberg
// parameters) and joint limits, with a parallel-jaw gripper or a pushing stick, written as MJCF by
// this project; and its controller: damped least-squares differential IK on MuJoCo's Jacobians with
// a null-space pull to a home posture, joint PD servos and gravity compensation.
#pragma once

#include <Eigen/Core>
#include <string>

#include "envs/mujoco/mj_util.h"

namespace dd::mj {

enum class Tool { kGripper, kStick };

using Vec7 = Eigen::Matrix<double, 7, 1>;

/// A whole arm scene: shared defaults and assets, the room (lights, floor, table with its top at
/// z = 0), `cameras`, the arm with `tool` at the origin, the task's `bodies`, and the arm's actuators.
/// The offscreen buffer is at least 640 px square (the console's view) and fits `camera_size`.
std::string arm_scene_xml(const std::string& model, Tool tool, int camera_size, const std::string& cameras,
                          const std::string& bodies);
/// The left and right cameras over the table (stacking, plugging), and the overview camera.
std::string side_cameras_xml();
std::string overview_camera_xml();

/// Joint limits [rad] from the Panda's datasheet.
Vec7 panda_lower();
Vec7 panda_upper();
/// A posture with the tool pointing down over the table.
Vec7 panda_home();

/// Control of the arm in a loaded model.
class PandaArm {
 public:
  PandaArm(const mjModel* m, Tool tool);

  Vec7 q(const mjData* d) const;
  Eigen::Vector3d tcp_pos(const mjData* d) const;
  Eigen::Matrix3d tcp_rot(const mjData* d) const;
  /// Finger opening [m] (the distance between the pads); 0 with the stick.
  double opening(const mjData* d) const;

  /// Places the arm at `q` at rest, gripper open, and sets the servos to hold it (no physics step).
  void set_posture(mjData* d, const Vec7& q) const;
  /// Joint positions that bring the TCP to (p, R), from the arm's current posture, by `iterations`
  /// damped least-squares steps computed on `scratch` (a second mjData of the same model). The
  /// result is within joint limits and at most `max_step` rad from the current posture per joint.
  Vec7 ik(const mjModel* m, const mjData* d, mjData* scratch, const Eigen::Vector3d& p, const Eigen::Matrix3d& R,
          int iterations = 8, double max_step = 0.25) const;
  /// Sets the servo targets (clamped to the limits) and the gripper command (0 open .. 1 closed).
  void command(mjData* d, const Vec7& q_target, double grip) const;
  /// Gravity and Coriolis compensation for the arm joints (call between mj_step1 and mj_step2).
  void compensate(const mjModel* m, mjData* d) const;

  int tcp_site() const { return tcp_; }
  Tool tool() const { return tool_; }

 private:
  Tool tool_;
  int tcp_ = -1;
  int qadr_[7], vadr_[7], act_[7];
  int finger_qadr_[2] = {-1, -1}, finger_act_[2] = {-1, -1};
};

}  // namespace dd::mj
