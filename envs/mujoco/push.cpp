#include "envs/mujoco/push.h"

#include <fmt/format.h>

#include <cmath>
#include <random>

namespace dd::mj {
namespace {

// The T: a bar 16 x 4 cm on a stem 4 x 12 cm, 4 cm tall; coordinates relative to the centre of mass.
constexpr double kComY = 0.0057;
struct Rect {
  double x0, x1, y0, y1;
};
constexpr Rect kBar{-0.08, 0.08, 0.02 - kComY, 0.06 - kComY};
constexpr Rect kStem{-0.02, 0.02, -0.10 - kComY, 0.02 - kComY};
constexpr double kHalfZ = 0.02;

double rect_distance(const Rect& r, const Eigen::Vector2d& p) {
  const double dx = std::max({r.x0 - p.x(), 0.0, p.x() - r.x1}), dy = std::max({r.y0 - p.y(), 0.0, p.y() - r.y1});
  if (dx > 0 || dy > 0) return std::hypot(dx, dy);
  return -std::min({p.x() - r.x0, r.x1 - p.x(), p.y() - r.y0, r.y1 - p.y()});
}

std::string t_geoms(const char* material, bool collide, double z) {
  std::string out;
  for (const Rect& r : {kBar, kStem})
    out += fmt::format(R"(      <geom type="box" pos="{} {} {}" size="{} {} {}" material="{}" {}/>
)",
                       (r.x0 + r.x1) / 2, (r.y0 + r.y1) / 2, z, (r.x1 - r.x0) / 2, (r.y1 - r.y0) / 2, kHalfZ, material,
                       collide ? R"(contype="2" conaffinity="2" mass="0.1")" : R"(class="visual")");
  return out;
}

}  // namespace

std::vector<TEdge> t_outline() {
  const Rect b = kBar, s = kStem;
  return {{{b.x0, b.y1}, {b.x1, b.y1}, {0, 1}},  {{b.x0, b.y0}, {b.x0, b.y1}, {-1, 0}}, {{b.x1, b.y0}, {b.x1, b.y1}, {1, 0}},
          {{b.x0, b.y0}, {s.x0, b.y0}, {0, -1}}, {{s.x1, b.y0}, {b.x1, b.y0}, {0, -1}}, {{s.x0, s.y0}, {s.x0, s.y1}, {-1, 0}},
          {{s.x1, s.y0}, {s.x1, s.y1}, {1, 0}},  {{s.x0, s.y0}, {s.x1, s.y0}, {0, -1}}};
}

double t_distance(const Eigen::Vector2d& p) { return std::min(rect_distance(kBar, p), rect_distance(kStem, p)); }

std::string push_xml(const PushConfig& c) {
  const std::string block = fmt::format(R"(    <body name="goal" pos="{gx} {gy} 0.0005" euler="0 0 {gyaw}">
{goal}    </body>
    <body name="tblock" pos="0 0 {z}">
      <joint name="block_x" type="slide" axis="1 0 0" damping="4" frictionloss="0.4" armature="0.05"/>
      <joint name="block_y" type="slide" axis="0 1 0" damping="4" frictionloss="0.4" armature="0.05"/>
      <joint name="block_yaw" type="hinge" axis="0 0 1" damping="0.05" frictionloss="0.01" armature="0.001"/>
{block}    </body>
)",
                                        fmt::arg("gx", c.goal.x()), fmt::arg("gy", c.goal.y()), fmt::arg("gyaw", c.goal.z()),
                                        fmt::arg("goal", t_geoms("goal", false, -kHalfZ + 0.0005)), fmt::arg("z", kHalfZ + 0.001),
                                        fmt::arg("block", t_geoms("blue", true, 0)));
  const std::string cameras =
      R"(    <camera name="top" pos="1.0 0 0.95" xyaxes="0 1 0 -0.89 0 0.45" fovy="40"/>
)" + overview_camera_xml();
  return arm_scene_xml("push", Tool::kStick, c.camera_size, cameras, block);
}

PushEnv::PushEnv(PushConfig config)
    : ArmEnv("push", push_xml(config), Tool::kStick, ArmControl::kJointDelta, config.time_limit), config_(config) {
  max_joint_step = 0.08;
  qx_ = model()->jnt_qposadr[id(model(), mjOBJ_JOINT, "block_x")];
  qy_ = model()->jnt_qposadr[id(model(), mjOBJ_JOINT, "block_y")];
  qyaw_ = model()->jnt_qposadr[id(model(), mjOBJ_JOINT, "block_yaw")];
  // the stick collides with the block (contype 2) as well as with the table
  const int stick = id(model(), mjOBJ_GEOM, "stick");
  model_->geom_contype[stick] = 3;
  model_->geom_conaffinity[stick] = 3;
  reset(0);
}

void PushEnv::reset(uint64_t seed) {
  reset_arm();
  std::mt19937_64 rng(seed * 0x9E3779B97F4A7C15ull + 37);
  std::uniform_real_distribution<double> u(0, 1);
  mjData* d = mutable_data();
  d->qpos[qx_] = config_.goal.x() - 0.07 + 0.14 * u(rng);
  d->qpos[qy_] = config_.goal.y() - 0.12 + 0.24 * u(rng);
  d->qpos[qyaw_] = config_.goal.z() + M_PI + (u(rng) - 0.5) * config_.start_yaw_spread;
  // the stick starts above the table, clear of the block
  mj_forward(model(), d);
  const Vec7 q = joint_targets({0.25, 0.0, 0.10});
  arm_.set_posture(d, q);
  mj_forward(model(), d);
}

Eigen::Vector3d PushEnv::block() const {
  return {data()->qpos[qx_], data()->qpos[qy_], std::remainder(data()->qpos[qyaw_], 2 * M_PI)};
}

bool PushEnv::at_goal() const {
  const Eigen::Vector3d b = block();
  return (b.head<2>() - config_.goal.head<2>()).norm() < config_.pos_tolerance &&
         std::abs(std::remainder(b.z() - config_.goal.z(), 2 * M_PI)) < config_.yaw_tolerance;
}

std::string PushEnv::outcome() const {
  if (success()) return "success";
  const Eigen::Vector3d b = block();
  const double yaw = std::abs(std::remainder(b.z() - config_.goal.z(), 2 * M_PI));
  if (yaw < config_.yaw_tolerance) return "turned, off in position";
  if ((b.head<2>() - config_.goal.head<2>()).norm() < config_.pos_tolerance) return "placed, off in yaw";
  if (yaw < M_PI / 2) return "half way";
  return "far";
}

Vec7 PushEnv::joint_targets(const Eigen::Vector3d& p) const {
  Eigen::Matrix3d down;
  down << 1, 0, 0, 0, -1, 0, 0, 0, -1;
  return ik_targets(p, down);
}

Vec PushEnv::observation() const {
  Vec o(24);
  int k = 0;
  arm_observation(o, k);
  const Eigen::Vector3d b = block();
  o[k++] = static_cast<float>(b.x());
  o[k++] = static_cast<float>(b.y());
  o[k++] = static_cast<float>(std::cos(b.z()));
  o[k++] = static_cast<float>(std::sin(b.z()));
  // Where the tip is on the T, and where the goal is seen from the T, both in the T's own frame: the
  // expert chooses contact points on the outline in that frame, and a network would otherwise have
  // to rotate world differences by the block's yaw itself (a product of inputs).
  const Eigen::Matrix2d Rt = Eigen::Rotation2Dd(b.z()).toRotationMatrix().transpose();
  const Eigen::Vector2d tip = Rt * (arm().tcp_pos(data()).head<2>() - b.head<2>());
  const Eigen::Vector2d goal = Rt * (config_.goal.head<2>() - b.head<2>());
  o[k++] = static_cast<float>(tip.x());
  o[k++] = static_cast<float>(tip.y());
  o[k++] = static_cast<float>(goal.x());
  o[k++] = static_cast<float>(goal.y());
  return o;
}

}  // namespace dd::mj
