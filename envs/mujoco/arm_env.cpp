#include "envs/mujoco/arm_env.h"

#include <spdlog/spdlog.h>

#include <cmath>

#include "core/config.h"

namespace dd::mj {

ArmEnv::ArmEnv(std::string name, const std::string& xml, Tool tool, ArmControl control, int time_limit)
    : name_(std::move(name)),
      model_(load_xml(xml, name_)),
      data_(mj_makeData(model_.get())),
      scratch_(mj_makeData(model_.get())),
      arm_(model_.get(), tool),
      control_(control),
      default_limit_(time_limit),
      limit_(time_limit) {}

ArmEnv::~ArmEnv() = default;

void ArmEnv::reset_arm() {
  mj_resetData(model_.get(), data_.get());
  arm_.set_posture(data_.get(), panda_home());
  steps_ = 0;
  limit_ = default_limit_;
  success_ = failed_ = false;
}

void ArmEnv::arm_observation(Vec& out, int& k) const {
  const Vec7 q = arm_.q(data_.get());
  for (int i = 0; i < 7; ++i) out[k++] = static_cast<float>(q[i]);
  const Eigen::Vector3d p = arm_.tcp_pos(data_.get());
  for (int i = 0; i < 3; ++i) out[k++] = static_cast<float>(p[i]);
  const auto r = rot6d(arm_.tcp_rot(data_.get()));
  for (int i = 0; i < 6; ++i) out[k++] = static_cast<float>(r[i]);
  if (arm_.tool() == Tool::kGripper) out[k++] = static_cast<float>(arm_.opening(data_.get()));
}

Vec7 ArmEnv::ik_targets(const Eigen::Vector3d& p, const Eigen::Matrix3d& R) const {
  return arm_.ik(model_.get(), data_.get(), scratch_.get(), p, R, 30, 10.0);
}

std::vector<Eigen::Vector3d> ArmEnv::action_points(const Mat& chunk) const {
  std::vector<Eigen::Vector3d> points;
  if (control_ != ArmControl::kEndEffectorPose || chunk.cols() < 3) return points;
  for (Eigen::Index r = 0; r < chunk.rows(); ++r) points.emplace_back(chunk(r, 0), chunk(r, 1), chunk(r, 2));
  return points;
}

StepResult ArmEnv::step(const Vec& action) {
  StepResult r;
  if (failed_ || steps_ >= limit_) {
    r.done = true;
    r.failed = failed_;
    r.success = success_;
    return r;
  }
  ++steps_;
  auto fail = [&](const std::string& why) {
    failed_ = true;
    success_ = false;
    r.done = r.failed = true;
    r.warning = name_ + ": " + why + " at step " + std::to_string(steps_) + "; the episode ends as failed";
    spdlog::warn("{}", r.warning);
    return r;
  };
  if (action.size() != action_dim()) return fail("action has " + std::to_string(action.size()) + " values, expected " + std::to_string(action_dim()));
  if (!action.allFinite()) return fail("non-finite action");
  mjModel* m = model_.get();
  mjData* d = data_.get();
  Vec7 target;
  double grip = 0;
  if (control_ == ArmControl::kEndEffectorPose) {
    // a safety box, like a real arm's: the TCP stays over the table and within reach
    const Eigen::Vector3d p = action.head<3>().cast<double>().cwiseMax(Eigen::Vector3d(0.15, -0.5, 0.005)).cwiseMin(Eigen::Vector3d(0.85, 0.5, 0.6));
    const Eigen::Matrix3d R = from_rot6d(action.segment<6>(3).cast<double>());
    grip = action[9];
    target = arm_.ik(m, d, scratch_.get(), p, R);
  } else {
    target = arm_.q(d) + action.head<7>().cast<double>().cwiseMax(-max_joint_step).cwiseMin(max_joint_step);
  }
  arm_.command(d, target, grip);
  try {
    for (int i = 0; i < kSubsteps; ++i) {
      mj_step1(m, d);  // positions and velocities: qfrc_bias of this very state
      arm_.compensate(m, d);
      mj_step2(m, d);
    }
  } catch (const Error& e) {
    return fail(std::string("simulation error (") + e.what() + ")");
  }
  if (!state_ok(m, d)) return fail("the simulation went unstable");
  success_ = check_success();
  r.success = success_;
  r.done = success_ || steps_ >= limit_;
  return r;
}

std::vector<double> ArmEnv::save_state() const {
  const mjModel* m = model_.get();
  const mjData* d = data_.get();
  std::vector<double> s;
  s.reserve(static_cast<size_t>(4 + m->nq + 2 * m->nv + m->nu + m->na));
  s.push_back(d->time);
  s.push_back(steps_);
  s.push_back(limit_);
  s.push_back(success_ ? 1 : 0);
  s.insert(s.end(), d->qpos, d->qpos + m->nq);
  s.insert(s.end(), d->qvel, d->qvel + m->nv);
  s.insert(s.end(), d->ctrl, d->ctrl + m->nu);
  s.insert(s.end(), d->act, d->act + m->na);
  s.insert(s.end(), d->qacc_warmstart, d->qacc_warmstart + m->nv);  // the solver's warm start
  return s;
}

void ArmEnv::restore_state(const std::vector<double>& s) {
  const mjModel* m = model_.get();
  mjData* d = data_.get();
  const size_t want = static_cast<size_t>(4 + m->nq + 2 * m->nv + m->nu + m->na);
  if (s.size() != want)
    throw Error(name_ + ": a saved state has " + std::to_string(s.size()) + " values, expected " + std::to_string(want));
  size_t k = 0;
  d->time = s[k++];
  steps_ = static_cast<int>(s[k++]);
  limit_ = static_cast<int>(s[k++]);
  success_ = s[k++] > 0.5;
  failed_ = false;
  for (int i = 0; i < m->nq; ++i) d->qpos[i] = s[k++];
  for (int i = 0; i < m->nv; ++i) d->qvel[i] = s[k++];
  for (int i = 0; i < m->nu; ++i) d->ctrl[i] = s[k++];
  for (int i = 0; i < m->na; ++i) d->act[i] = s[k++];
  for (int i = 0; i < m->nv; ++i) d->qacc_warmstart[i] = s[k++];
  mj_forward(m, d);
}

}  // namespace dd::mj
