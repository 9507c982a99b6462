#include "envs/mujoco/push_expert.h"

#include <cmath>

#include "core/config.h"

namespace dd::mj {
namespace {

constexpr double kTipZ = 0.02;      // stick tip height while pushing (mid-height of the block) [m]
constexpr double kLiftZ = 0.068;    // over the block [m]
constexpr double kStandoff = 0.025;  // tip distance from the outline before a push [m]
constexpr double kGyration = 0.05;  // the block's radius of gyration for friction [m]

Eigen::Matrix2d rot(double yaw) {
  Eigen::Matrix2d R;
  R << std::cos(yaw), -std::sin(yaw), std::sin(yaw), std::cos(yaw);
  return R;
}

double cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() * b.y() - a.y() * b.x(); }

}  // namespace

std::string PushExpert::name() const {
  switch (mode_) {
    case Mode::kClockwise: return "push_cw";
    case Mode::kCounterClockwise: return "push_ccw";
    case Mode::kMixed: return "push_mixed";
    case Mode::kAlternate: return "push_alternate";
  }
  return "push";
}

void PushExpert::reset(uint64_t seed) {
  current_ = mode_;
  if (mode_ == Mode::kMixed) {
    std::mt19937_64 rng(seed * 7919 + 3);
    current_ = std::uniform_int_distribution<int>(0, 1)(rng) ? Mode::kClockwise : Mode::kCounterClockwise;
  } else if (mode_ == Mode::kAlternate) {
    current_ = seed % 2 == 0 ? Mode::kClockwise : Mode::kCounterClockwise;
  }
  phase_ = Phase::kChoose;
  pushed_ = 0;
  have_target_ = false;
}

void PushExpert::choose_contact(const PushEnv& env) {
  const Eigen::Vector3d b = env.block(), goal = env.config().goal;
  // the wanted motion: towards the goal, and turning in this expert's sense
  const Eigen::Vector2d v = goal.head<2>() - b.head<2>();
  double turn = std::remainder(goal.z() - b.z(), 2 * M_PI);  // shortest way, in (-pi, pi]
  if (std::abs(turn) > 0.5) {
    const double ccw = std::fmod(goal.z() - b.z() + 8 * M_PI, 2 * M_PI);  // in [0, 2 pi)
    turn = current_ == Mode::kCounterClockwise ? ccw : ccw - 2 * M_PI;
  }
  // far from the goal yaw, turning comes first and the translation only breaks ties
  const double w_rot = std::min(std::abs(turn), 1.0) * 2.0;
  const double w_pos = (std::abs(turn) > 0.4 ? 0.3 : 1.0) * std::min(v.norm() / 0.04, 1.0);
  const Eigen::Vector2d vd = v / std::max(v.norm(), 1e-6) * w_pos;
  const Eigen::Vector3d want(vd.x(), vd.y(), turn > 0 ? w_rot : -w_rot);
  const Eigen::Vector3d tip = env.arm().tcp_pos(env.data());
  const Eigen::Matrix2d R = rot(b.z());
  double best = -1e9;
  for (const TEdge& e : t_outline()) {
    const double len = (e.b - e.a).norm();
    const int n = std::max(1, static_cast<int>(len / 0.01));
    for (int i = 0; i <= n; ++i) {
      const Eigen::Vector2d c = e.a + (e.b - e.a) * (double(i) / n);
      const Eigen::Vector2d out = c + e.normal * 0.012;
      if (t_distance(out) < 0.011) continue;  // a concave corner: the stick would not fit
      if (t_distance(c + e.normal * kStandoff) < 0.016) continue;  // nor stand off before the push
      const Eigen::Vector2d r = R * c, d = -(R * e.normal);
      const Eigen::Vector3d pred(d.x(), d.y(), cross(r, d) / kGyration);
      const Eigen::Vector2d pre = b.head<2>() + R * (c + e.normal * kStandoff);
      const double score = want.dot(pred) / pred.norm() - 0.5 * (pre - tip.head<2>()).norm();
      if (score > best) best = score, contact_ = c, normal_ = e.normal;
    }
  }
}

Vec PushExpert::act(const Env& base) {
  const auto* env = dynamic_cast<const PushEnv*>(&base);
  if (!env) throw Error("push expert: the env is not a PushEnv");
  const Eigen::Vector3d tip = env->arm().tcp_pos(env->data());
  if (!have_target_ || (target_ - tip).norm() > 0.1) target_ = tip;
  have_target_ = true;
  const Eigen::Vector3d b = env->block();
  const Eigen::Matrix2d R = rot(b.z());
  auto to_block = [&](const Eigen::Vector3d& p) { return Eigen::Vector2d(R.transpose() * (p.head<2>() - b.head<2>())); };

  if (phase_ == Phase::kChoose) {
    choose_contact(*env);
    phase_ = Phase::kApproach;
  }
  Eigen::Vector2d pre_xy = b.head<2>() + R * (contact_ + normal_ * kStandoff);
  if (phase_ == Phase::kApproach && t_distance(to_block({pre_xy.x(), pre_xy.y(), 0})) < 0.02) {
    choose_contact(*env);  // the block moved under the chosen point
    pre_xy = b.head<2>() + R * (contact_ + normal_ * kStandoff);
  }
  if (phase_ == Phase::kPush && tip.z() > kTipZ + 0.015) {
    // riding on the block instead of pushing its side: lift and choose again
    phase_ = Phase::kApproach;
    target_.z() = kLiftZ;
    choose_contact(*env);
    pre_xy = b.head<2>() + R * (contact_ + normal_ * kStandoff);
  }
  Eigen::Vector3d goal = target_;  // every phase below sets it
  double step = speed;
  if (phase_ == Phase::kApproach) {
    // judged from where the tip is, not from where it was told to go
    const bool near = (tip.head<2>() - pre_xy).norm() < 0.008;
    if (near && tip.z() <= kTipZ + 0.006) {
      phase_ = Phase::kPush;
      pushed_ = 0;
    } else {
      // down only when over the standoff point, up when the straight way would cross the block
      bool blocked = false;
      for (int i = 0; i < 10; ++i) {  // would the stick (radius 12 mm) touch the block on the way?
        const Eigen::Vector3d p = tip + (Eigen::Vector3d(pre_xy.x(), pre_xy.y(), tip.z()) - tip) * (i / 10.0);
        if (t_distance(to_block(p)) < 0.015) blocked = true;
      }
      if (blocked && tip.z() < kLiftZ - 0.01) goal = {tip.x(), tip.y(), kLiftZ};
      else if (!near) goal = {pre_xy.x(), pre_xy.y(), blocked ? kLiftZ : target_.z()};
      else goal = {pre_xy.x(), pre_xy.y(), kTipZ};
    }
  }
  if (phase_ == Phase::kPush) {
    const Eigen::Vector2d in = -(R * normal_);
    const double turn_now = std::abs(std::remainder(env->config().goal.z() - b.z(), 2 * M_PI));
    step = turn_now > 0.4 ? push_speed * 1.4 : push_speed;  // long strokes while turning, careful ones at the end
    goal = target_ + Eigen::Vector3d(in.x(), in.y(), 0) * step;
    goal.z() = kTipZ;
    // near the goal yaw, stop as soon as this push would overshoot the goal position or yaw
    const Eigen::Vector3d goal_pose = env->config().goal;
    const double turn = std::remainder(goal_pose.z() - b.z(), 2 * M_PI);
    const bool fine = std::abs(turn) < 0.4;
    const bool past = fine && pushed_ > 1 &&
                      ((goal_pose.head<2>() - b.head<2>()).dot(in) < 0.004 || turn * stroke_turn_ < 0);
    if (pushed_ == 0) stroke_turn_ = turn;
    if (++pushed_ >= stroke || env->at_goal() || past) {
      phase_ = Phase::kChoose;
      // back off a little before the next choice, so the stick does not drag along the block
      goal = target_ - Eigen::Vector3d(in.x(), in.y(), 0) * 0.01;
    }
  }
  const Eigen::Vector3d d = goal - target_;
  target_ += d.norm() > step ? Eigen::Vector3d(d.normalized() * step) : d;
  const Eigen::Vector3d lead = target_ - tip;  // never run far ahead of the tip
  if (lead.norm() > 0.03) target_ = tip + lead.normalized() * 0.03;
  const Vec7 q = env->arm().q(env->data());
  const Vec7 dq = (env->joint_targets(target_) - q).cwiseMax(-env->max_joint_step).cwiseMin(env->max_joint_step);
  return dq.cast<float>();
}

}  // namespace dd::mj
