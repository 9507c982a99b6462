#include "envs/mujoco/stack.h"

#include <fmt/format.h>

#include <cmath>
#include <random>

namespace dd::mj {

std::string stack_xml(const StackConfig& c) {
  const std::string cubes = fmt::format(R"(    <body name="red" pos="0.5 0 {rh}">
      <freejoint name="red"/>
      <geom type="box" size="{rh} {rh} {rh}" material="red" mass="0.05" condim="4"/>
    </body>
    <body name="green" pos="0.5 0.2 {gh}">
      <freejoint name="green"/>
      <geom type="box" size="{gh} {gh} {gh}" material="green" mass="0.3" condim="4"/>
    </body>
)",
                                        fmt::arg("rh", c.red_half), fmt::arg("gh", c.green_half));
  return arm_scene_xml("stack", Tool::kGripper, c.camera_size, side_cameras_xml() + overview_camera_xml(), cubes);
}

StackEnv::StackEnv(StackConfig config)
    : ArmEnv("stack", stack_xml(config), Tool::kGripper, ArmControl::kEndEffectorPose, config.time_limit), config_(config) {
  red_ = id(model(), mjOBJ_BODY, "red");
  green_ = id(model(), mjOBJ_BODY, "green");
  reset(0);
}

void StackEnv::reset(uint64_t seed) {
  reset_arm();
  std::mt19937_64 rng(seed * 0x9E3779B97F4A7C15ull + 11);
  std::uniform_real_distribution<double> ux(config_.x_range[0], config_.x_range[1]), uy(config_.y_range[0], config_.y_range[1]),
      uyaw(-M_PI / 4, M_PI / 4);
  Eigen::Vector2d r, g;
  do {
    r = {ux(rng), uy(rng)};
    g = {ux(rng), uy(rng)};
  } while ((r - g).norm() < config_.min_separation);
  mjData* d = mutable_data();
  auto yaw_quat = [](double yaw) { return Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ())); };
  set_free_pose(model(), d, red_, {r.x(), r.y(), config_.red_half}, yaw_quat(uyaw(rng)));
  red_start_ = {r.x(), r.y(), config_.red_half};
  set_free_pose(model(), d, green_, {g.x(), g.y(), config_.green_half}, yaw_quat(uyaw(rng)));
  mj_forward(model(), d);
}

Vec StackEnv::observation() const {
  Vec o(37);
  int k = 0;
  arm_observation(o, k);
  const Eigen::Vector3d tcp = arm().tcp_pos(data()), red = red_pos(), green = green_pos();
  for (int b : {red_, green_}) {
    const Eigen::Vector3d p = free_pos(model(), data(), b);
    const Eigen::Quaterniond q = free_quat(model(), data(), b);
    for (int i = 0; i < 3; ++i) o[k++] = static_cast<float>(p[i]);
    o[k++] = static_cast<float>(q.w());
    o[k++] = static_cast<float>(q.x());
    o[k++] = static_cast<float>(q.y());
    o[k++] = static_cast<float>(q.z());
  }
  for (int i = 0; i < 3; ++i) o[k++] = static_cast<float>(red[i] - tcp[i]);
  for (int i = 0; i < 3; ++i) o[k++] = static_cast<float>(green[i] - red[i]);
  return o;
}

namespace {
double yaw_of(const Eigen::Quaterniond& q) {
  const Eigen::Vector3d x = q.toRotationMatrix().col(0);
  return std::atan2(x.y(), x.x());
}
}  // namespace

double StackEnv::red_yaw() const { return yaw_of(free_quat(model(), data(), red_)); }
double StackEnv::green_yaw() const { return yaw_of(free_quat(model(), data(), green_)); }

bool StackEnv::red_on_green() const {
  const Eigen::Vector3d r = red_pos(), g = green_pos();
  const double rest = g.z() + config_.green_half + config_.red_half;
  return (r.head<2>() - g.head<2>()).norm() < 0.02 && std::abs(r.z() - rest) < 0.01;
}

std::string StackEnv::outcome() const {
  if (success()) return "success";
  if (red_on_green()) return "on green, not released";
  const Eigen::Vector3d r = red_pos();
  const bool between = (arm().tcp_pos(data()) - r).norm() < 0.03;
  if (between && r.z() > config_.red_half + 0.01) return "held";
  if ((r.head<2>() - green_pos().head<2>()).norm() < 0.06) return r.z() > config_.red_half + 0.01 ? "leaning on green" : "beside green";
  if ((r - red_start_).norm() > 0.01) return "moved";
  return "not grasped";
}

bool StackEnv::check_success() const {
  return red_on_green() && arm().opening(data()) >= 0.06 && arm().tcp_pos(data()).z() > red_pos().z();
}

}  // namespace dd::mj
