#include "envs/mujoco/stack_expert.h"

#include <cmath>

#include "core/config.h"
#include "envs/mujoco/planner.h"

namespace dd::mj {

Eigen::Matrix3d tool_down(double yaw) {
  Eigen::Matrix3d base;
  base << 1, 0, 0, 0, -1, 0, 0, 0, -1;  // x forward, z down
  return Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix() * base;
}

double tool_yaw(const Eigen::Matrix3d& R) { return std::atan2(R(1, 0), R(0, 0)); }

namespace {

// The cube's yaw (a quarter-turn symmetry) nearest to the tool's current yaw.
double nearest_grasp_yaw(double cube_yaw, double tool) {
  double best = cube_yaw, err = 1e9;
  for (int k = -4; k <= 4; ++k) {
    const double y = cube_yaw + k * M_PI / 2;
    const double e = std::abs(std::remainder(y - tool, 2 * M_PI));
    if (e < err) err = e, best = tool + std::remainder(y - tool, 2 * M_PI);
  }
  return best;
}

}  // namespace

void StackExpert::reset(uint64_t seed) {
  seed_ = seed;
  closing_ = opening_ = 0;
  have_target_ = have_yaw_ = false;
  path_.clear();
  path_goal_ = {1e9, 0, 0};
}

Vec StackExpert::command(const Eigen::Vector3d& p, const Eigen::Matrix3d& R, double grip) {
  Vec a(10);
  a.head<3>() = p.cast<float>();
  a.segment<6>(3) = rot6d(R).cast<float>();
  a[9] = static_cast<float>(grip);
  return a;
}

Eigen::Vector3d StackExpert::follow(const StackEnv& env, const Eigen::Vector3d& goal, double max_step, bool holding) {
  const Eigen::Vector3d tcp = env.arm().tcp_pos(env.data());
  if (!have_target_ || (target_ - tcp).norm() > 0.06) target_ = tcp;  // lagging or taking over: restart here
  have_target_ = true;
  if ((goal - path_goal_).norm() > 0.01) {
    // plan around the green cube (and the red one when not carrying it), out of the table
    const StackConfig& c = env.config();
    const double reach = holding ? c.red_half * 2 + 0.02 : 0.03;  // what hangs below the TCP
    std::vector<Box3> obstacles;
    const Eigen::Vector3d g = env.green_pos();
    const double m = c.green_half + 0.035;
    obstacles.push_back({{g.x() - m, g.y() - m, -1}, {g.x() + m, g.y() + m, g.z() + c.green_half + reach}});
    PlannerConfig pc;
    pc.bounds.lo.z() = std::min(goal.z(), target_.z()) - 0.01;
    path_ = plan_path(target_, goal, obstacles, seed_ + 17, pc);
    if (path_.empty()) {  // fall back to a raised straight path
      const double z = std::max({goal.z(), target_.z(), 0.2});
      path_ = {target_, {target_.x(), target_.y(), z}, {goal.x(), goal.y(), z}, goal};
    }
    path_goal_ = goal;
    path_i_ = 1;
  }
  double budget = max_step;
  while (path_i_ < path_.size() && budget > 1e-9) {
    const Eigen::Vector3d d = path_[path_i_] - target_;
    if (d.norm() <= budget) {
      budget -= d.norm();
      target_ = path_[path_i_++];
    } else {
      target_ += d.normalized() * budget;
      budget = 0;
    }
  }
  return target_;
}

Vec StackExpert::act(const Env& base) {
  const auto* env = dynamic_cast<const StackEnv*>(&base);
  if (!env) throw Error("stack expert: the env is not a StackEnv");
  const StackConfig& c = env->config();
  const mjData* d = env->data();
  const Eigen::Vector3d tcp = env->arm().tcp_pos(d), r = env->red_pos(), g = env->green_pos();
  const double opening = env->arm().opening(d);
  const double tool = tool_yaw(env->arm().tcp_rot(d));
  const bool between_fingers = (tcp - r).norm() < 0.02;
  const bool holding = between_fingers && opening > 2 * c.red_half - 0.008 && opening < 2 * c.red_half + 0.006;

  // released on the green cube: open fully, then back off upwards
  if (env->red_on_green()) {
    closing_ = 0;
    const Eigen::Matrix3d R = env->arm().tcp_rot(d);
    const Eigen::Matrix3d Rd = tool_down(tool_yaw(R));
    if (opening < 0.07) {
      ++opening_;
      return command(have_target_ ? target_ : tcp, Rd, 0.0);
    }
    const Eigen::Vector3d up(r.x(), r.y(), r.z() + 0.12);
    return command(follow(*env, up, slow, false), Rd, 0.0);
  }
  opening_ = 0;

  if (holding && closing_ >= 6) {
    // carry: above the green cube, then down until the red one sits on it
    const Eigen::Matrix3d R = tool_down(have_yaw_ ? yaw_ : tool);
    const Eigen::Vector3d place(g.x(), g.y(), g.z() + c.green_half + c.red_half + 0.004);
    const Eigen::Vector3d above = place + Eigen::Vector3d(0, 0, 0.08);
    const double xy = (tcp.head<2>() - place.head<2>()).norm();
    if (xy > 0.006 && !(xy < 0.012 && tcp.z() < above.z() - 0.01)) return command(follow(*env, above, speed, true), R, 1.0);
    if (tcp.z() - place.z() > 0.004) return command(follow(*env, place, slow * 0.6, true), R, 1.0);
    // in place: let go (the branch above takes over once the cube rests on the green one)
    closing_ = 0;
    return command(target_, R, 0.0);
  }

  // reach and grasp the red cube
  if (!have_yaw_ || closing_ == 0) {
    yaw_ = nearest_grasp_yaw(env->red_yaw(), tool);
    have_yaw_ = true;
  }
  const Eigen::Matrix3d R = tool_down(yaw_);
  if (closing_ > 0) {  // closing on the cube: hold still for a few steps
    if (++closing_ < 8) return command(target_, R, 1.0);
    if (holding) return command(target_ + Eigen::Vector3d(0, 0, 0.01), R, 1.0);
    closing_ = 0;  // missed: open and try again
    path_goal_ = {1e9, 0, 0};
    return command(tcp + Eigen::Vector3d(0, 0, 0.02), R, 0.0);
  }
  if (opening < 0.07 && !between_fingers) return command(have_target_ ? target_ : tcp, R, 0.0);  // open before reaching
  const Eigen::Vector3d grasp(r.x(), r.y(), r.z() + 0.002);
  const Eigen::Vector3d pre = grasp + Eigen::Vector3d(0, 0, 0.08);
  const double xy = (tcp.head<2>() - grasp.head<2>()).norm();
  const double yaw_err = std::abs(std::remainder(tool - yaw_, 2 * M_PI));
  if ((xy > 0.006 || yaw_err > 0.08) && !(xy < 0.012 && tcp.z() < pre.z() - 0.01 && yaw_err < 0.12))
    return command(follow(*env, pre, speed, false), R, 0.0);
  if (tcp.z() - grasp.z() > 0.004) return command(follow(*env, grasp, slow, false), R, 0.0);
  closing_ = 1;
  return command(target_, R, 1.0);
}

}  // namespace dd::mj
