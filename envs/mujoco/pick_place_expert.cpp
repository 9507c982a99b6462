#include "envs/mujoco/pick_place_expert.h"

#include <random>

#include <cmath>

#include "core/config.h"

namespace dd::mj {

Eigen::Matrix3d tool_down(double yaw) {
  Eigen::Matrix3d base;
  base << 1, 0, 0, 0, -1, 0, 0, 0, -1;  // x forward, z down
  return Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix() * base;
}

double tool_yaw(const Eigen::Matrix3d& R) { return std::atan2(R(1, 0), R(0, 0)); }

namespace {

// The object's yaw (a quarter-turn symmetry) nearest to the tool's current yaw.
double nearest_grasp_yaw(double object_yaw, double tool) {
  double best = object_yaw, err = 1e9;
  for (int k = -4; k <= 4; ++k) {
    const double e = std::remainder(object_yaw + k * M_PI / 2 - tool, 2 * M_PI);
    if (std::abs(e) < err) err = std::abs(e), best = tool + e;
  }
  return best;
}

}  // namespace

void PickPlaceExpert::reset(uint64_t seed) {
  seed_ = seed;
  closing_ = 0;
  lowering_ = false;
  have_target_ = have_yaw_ = false;
  path_.clear();
  path_goal_ = {1e9, 0, 0};
  pre_detoured_ = hover_detoured_ = detour <= 0;
  if (detour > 0) {
    std::mt19937_64 rng(seed * 0x9E3779B97F4A7C15ull + 101);
    std::uniform_real_distribution<double> angle(-M_PI, M_PI), radius(0.5 * detour, detour);
    for (Eigen::Vector2d* v : {&pre_detour_, &hover_detour_}) {
      const double a = angle(rng), r = radius(rng);
      *v = {r * std::cos(a), r * std::sin(a)};
    }
  }
}

Eigen::Vector3d PickPlaceExpert::via_detour(const Eigen::Vector3d& tcp, const Eigen::Vector3d& goal, const Eigen::Vector2d& offset,
                                            bool& done) {
  if (done) return goal;
  const Eigen::Vector3d via = goal + Eigen::Vector3d(offset.x(), offset.y(), 0);
  // reached it, or taking over close to the goal already: no detour
  if ((tcp - via).norm() < 0.006 || (tcp - goal).norm() < 0.5 * detour) {
    done = true;
    path_goal_ = {1e9, 0, 0};  // plan afresh to the goal, however close it is to the detour point
    return goal;
  }
  return via;
}

Vec PickPlaceExpert::command(const Eigen::Vector3d& p, const Eigen::Matrix3d& R, double grip) {
  Vec a(10);
  a.head<3>() = p.cast<float>();
  a.segment<6>(3) = rot6d(R).cast<float>();
  a[9] = static_cast<float>(grip);
  return a;
}

Eigen::Vector3d PickPlaceExpert::follow(const ArmEnv& env, const PickPlaceState& s, const Eigen::Vector3d& goal, double max_step,
                                        bool holding) {
  const Eigen::Vector3d tcp = env.arm().tcp_pos(env.data());
  if (!have_target_ || (target_ - tcp).norm() > 0.06) target_ = tcp;  // lagging, or just taking over: restart here
  have_target_ = true;
  if ((goal - path_goal_).norm() > 0.01) {
    // the obstacles grow by what hangs below the TCP
    std::vector<Box3> obstacles = s.obstacles;
    const double reach = holding ? s.hang + 0.02 : 0.03;
    for (Box3& b : obstacles) b.hi.z() += reach;
    PlannerConfig pc;
    pc.bounds.lo.z() = std::min(goal.z(), target_.z()) - 0.01;
    path_ = plan_path(target_, goal, obstacles, seed_ + 17, pc);
    if (path_.empty()) {  // fall back to a raised straight path
      const double z = std::max({goal.z(), target_.z(), 0.22});
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

Vec PickPlaceExpert::act(const Env& base) {
  const auto* env = dynamic_cast<const ArmEnv*>(&base);
  if (!env) throw Error(name() + ": the env is not an arm task");
  const PickPlaceState s = read(*env);
  const mjData* d = env->data();
  const Eigen::Vector3d tcp = env->arm().tcp_pos(d);
  const double opening = env->arm().opening(d);
  const double tool = tool_yaw(env->arm().tcp_rot(d));
  const bool between_fingers = (tcp - s.object).norm() < 0.02;
  const bool holding = between_fingers && opening > s.width - 0.008 && opening < s.width + 0.006;

  // in place: open fully, then back off upwards
  if (s.placed) {
    closing_ = 0;
    const Eigen::Matrix3d R = tool_down(tool);
    if (opening < 0.07) return command(have_target_ ? target_ : tcp, R, 0.0);
    const Eigen::Vector3d up(s.object.x(), s.object.y(), s.object.z() + 0.12);
    return command(follow(*env, s, up, slow, false), R, 0.0);
  }

  if (holding && closing_ >= 6) {
    // carry: over the target, then lower; the final approach corrects for the grasp offset
    double carry_yaw = have_yaw_ ? yaw_ : tool, yaw_err = 0;
    if (s.align_yaw) {
      yaw_err = std::remainder(s.place_yaw - s.object_yaw, M_PI / 2);
      carry_yaw = tool + std::clamp(yaw_err, -0.15, 0.15);
    }
    const Eigen::Matrix3d R = tool_down(carry_yaw);
    const Eigen::Vector3d offset = tcp - s.object;
    const Eigen::Vector3d place = s.place + offset;
    const Eigen::Vector3d above = place + Eigen::Vector3d(0, 0, s.approach);
    const double xy = (s.object.head<2>() - s.place.head<2>()).norm();
    if (!lowering_ && xy < 0.005 && std::abs(yaw_err) < 0.03 && std::abs(tcp.z() - above.z()) < 0.01) lowering_ = true;
    if (lowering_ && xy > 0.015) lowering_ = false;  // knocked off: go back up over the target
    if (!lowering_ && (s.object.head<2>() - s.place.head<2>()).norm() > 0.02 && s.object.z() < s.place.z() + s.lift) {
      // lift straight up out of wherever the object was before moving across
      if (!have_target_) target_ = tcp;
      if (!s.plumb_lift) {
        target_ = Eigen::Vector3d(tcp.x(), tcp.y(), std::min(target_.z(), tcp.z() + 0.02) + slow);
        path_goal_ = {1e9, 0, 0};
        return command(target_, R, 1.0);
      }
      // plumb, out of a snug hole: the commanded xy stays where the lift began (unless the TCP is a
      // centimetre off it, taking over mid-episode), and the object is not turned until it is out. A
      // TCP pushed aside by the contact, or a turn, wedges the prong and levers it out sideways.
      if ((target_.head<2>() - tcp.head<2>()).norm() > 0.01) target_ = tcp;
      target_ = Eigen::Vector3d(target_.x(), target_.y(), std::min(target_.z(), tcp.z() + 0.02) + slow);
      path_goal_ = {1e9, 0, 0};
      return command(target_, tool_down(tool), 1.0);
    }
    if (!lowering_) {
      const Eigen::Vector3d goal = via_detour(tcp, above, hover_detour_, hover_detoured_);
      const double step = (tcp - goal).norm() < 0.03 ? slow * 0.4 : speed;
      return command(follow(*env, s, goal, step, true), R, 1.0);
    }
    // lower straight down, re-centring on the object's own position at every step
    if (!have_target_) target_ = tcp;
    target_.head<2>() = place.head<2>();
    target_.z() = std::max(place.z() - 0.004, std::min(target_.z(), tcp.z() + 0.01) - s.lower_speed);
    path_goal_ = {1e9, 0, 0};
    return command(target_, R, 1.0);
  }
  lowering_ = false;

  // reach and grasp
  if (!have_yaw_ || closing_ == 0) {
    yaw_ = nearest_grasp_yaw(s.object_yaw, tool);
    have_yaw_ = true;
  }
  const Eigen::Matrix3d R = tool_down(yaw_);
  if (closing_ > 0) {  // closing: hold still for a few steps
    if (++closing_ < 8) return command(target_, R, 1.0);
    if (holding) return command(target_ + Eigen::Vector3d(0, 0, 0.01), R, 1.0);
    closing_ = 0;  // missed: open and try again
    path_goal_ = {1e9, 0, 0};
    return command(tcp + Eigen::Vector3d(0, 0, 0.02), R, 0.0);
  }
  if (opening < 0.07 && !between_fingers) return command(have_target_ ? target_ : tcp, R, 0.0);  // open before reaching
  const Eigen::Vector3d grasp(s.object.x(), s.object.y(), s.object.z() + 0.002);
  const Eigen::Vector3d pre = grasp + Eigen::Vector3d(0, 0, 0.08);
  const double xy = (tcp.head<2>() - grasp.head<2>()).norm();
  const double yaw_err = std::abs(std::remainder(tool - yaw_, 2 * M_PI));
  if ((xy > 0.006 || yaw_err > 0.08) && !(xy < 0.012 && tcp.z() < pre.z() - 0.01 && yaw_err < 0.12))
    return command(follow(*env, s, via_detour(tcp, pre, pre_detour_, pre_detoured_), speed, false), R, 0.0);
  if (tcp.z() - grasp.z() > 0.004) return command(follow(*env, s, grasp, slow, false), R, 0.0);
  closing_ = 1;
  return command(target_, R, 1.0);
}

}  // namespace dd::mj
