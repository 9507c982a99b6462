// The operator's teleoperation of the arm tasks: a TCP target that moves with the jog (in the view's
// ground plane), the lift, or a dragged point, kept within reach of the TCP; the tool points down at
// the yaw it had when the takeover began; the gripper toggles.
#include <algorithm>
#include <cmath>

#include "envs/mujoco/arm_env.h"
#include "envs/mujoco/mj_util.h"
#include "envs/mujoco/pick_place_expert.h"

namespace dd::mj {
namespace {

class ArmTeleoperation : public Teleoperation {
 public:
  void begin() override { valid_ = false; }
  void toggle_grip() override { grip_ = grip_ > 0.5 ? 0.0 : 1.0; }
  std::optional<Eigen::Vector3d> target() const override {
    if (!valid_) return std::nullopt;
    return target_;
  }

  Vec action(const Env& base, const OperatorInput& in) override {
    const ArmEnv& env = static_cast<const ArmEnv&>(base);  // made by ArmEnv::teleoperation for this env
    const Eigen::Vector3d tcp = env.arm().tcp_pos(env.data());
    if (!valid_) {
      target_ = tcp;
      yaw_ = tool_yaw(env.arm().tcp_rot(env.data()));
      grip_ = env.arm().opening(env.data()) < 0.06 ? 1.0 : 0.0;
      valid_ = true;
    }
    if (in.has_target) {
      target_.head<2>() = in.target;
    } else {
      const Eigen::Vector2d right(in.forward.y(), -in.forward.x());
      const Eigen::Vector2d d = (in.forward * in.jog.y() + right * in.jog.x()) * kJogStep;
      target_ += Eigen::Vector3d(d.x(), d.y(), kJogStep * in.lift);
    }
    target_.z() = std::clamp(target_.z(), 0.0, 0.5);
    if ((target_ - tcp).norm() > kReach) target_ = tcp + (target_ - tcp).normalized() * kReach;  // stay reachable
    const Eigen::Matrix3d R = tool_down(yaw_);
    if (env.control() == ArmControl::kEndEffectorPose) {
      Vec a(10);
      a.head<3>() = target_.cast<float>();
      a.segment<6>(3) = rot6d(R).cast<float>();
      a[9] = static_cast<float>(grip_);
      return a;
    }
    const Vec7 dq = (env.ik_targets(target_, R) - env.arm().q(env.data())).cwiseMax(-env.max_joint_step).cwiseMin(env.max_joint_step);
    return dq.cast<float>();
  }

 private:
  static constexpr double kJogStep = 0.01;  // m per step at full jog
  static constexpr double kReach = 0.08;    // the target keeps within this of the TCP
  bool valid_ = false;
  Eigen::Vector3d target_{0, 0, 0};
  double yaw_ = 0, grip_ = 0;
};

}  // namespace

std::unique_ptr<Teleoperation> ArmEnv::teleoperation() const { return std::make_unique<ArmTeleoperation>(); }

}  // namespace dd::mj
