#include "envs/mujoco/plug.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <random>

namespace dd::mj {
namespace {
constexpr double kWall = 0.035;       // socket depth and receptacle height [m]
constexpr double kHandleHalfZ = 0.015;
constexpr double kProngHalfZ = 0.015;
constexpr double kEighthTurn = M_PI / 4;  // the scene compiles angles in radians

// Four walls of height h around a square hole of half-width `hole`, walls `thick` thick. With a
// chamfer c > 0 the top c of each wall steps back by c and a 45-degree slope (a box turned on its edge)
// fills the step, so the hole widens to hole + c at the top: a lead-in funnel.
std::string walled_hole(double hole, double thick, double h, const char* material, double c = 0) {
  std::string out;
  auto box = [&](double x, double y, double z, double hx, double hy, double hz, double pitch, double roll) {
    out += fmt::format(R"(      <geom type="box" pos="{} {} {}" size="{} {} {}" euler="{} {} 0" material="{}"/>
)",
                       x, y, z, hx, hy, hz, roll, pitch, material);
  };
  // one layer of walls with inner face at half-width `in` and outer face at hole + thick, z in [z0, z1]
  auto layer = [&](double in, double z0, double z1) {
    const double o = hole + thick, t = (o - in) / 2, m = in + t, zc = (z0 + z1) / 2, hz = (z1 - z0) / 2;
    box(0, m, zc, o, t, hz, 0, 0);
    box(0, -m, zc, o, t, hz, 0, 0);
    box(m, 0, zc, t, in, hz, 0, 0);
    box(-m, 0, zc, t, in, hz, 0, 0);
  };
  if (c <= 0) {
    layer(hole, 0, h);
    return out;
  }
  layer(hole, 0, h - c);
  layer(hole + c, h - c, h);
  // a square rod of half-side c / sqrt(2) turned 45 degrees about its length, centred c out and c
  // down from the hole's top edge: its upper inner face runs from (hole, h - c) to (hole + c, h)
  const double a = c / std::sqrt(2.0), r = hole + c, len = hole + thick;
  box(0, r, h - c, len, a, a, 0, kEighthTurn);
  box(0, -r, h - c, len, a, a, 0, kEighthTurn);
  box(r, 0, h - c, a, len, a, kEighthTurn, 0);
  box(-r, 0, h - c, a, len, a, kEighthTurn, 0);
  return out;
}

}  // namespace

std::string plug_xml(const PlugConfig& c) {
  // the receptacle and the dock are mocap bodies: fixed in the physics, placed per episode; the dock
  // holds the prong as the socket does, 1 mm a side
  const std::string bodies = fmt::format(R"(    <body name="receptacle" mocap="true" pos="0.5 0.15 0">
{receptacle}      <site name="socket" pos="0 0 0" size="0.004" rgba="1 1 0 0.5" group="2"/>
    </body>
    <body name="dock" mocap="true" pos="0.5 -0.15 0">
{dock}    </body>
    <body name="charger" pos="0.5 -0.15 0.045">
      <freejoint name="charger"/>
      <geom name="handle" type="box" size="{hh} {hh} {hz}" material="white" mass="0.04" condim="4"/>
      <geom name="prong" type="box" pos="0 0 -{pz2}" size="{ph} {ph} {pz}" material="red" mass="0.01" condim="4" friction="0.3 0.005 0.0001"/>
    </body>
)",
                                         fmt::arg("receptacle", walled_hole(c.socket_half, 0.03, kWall, "blue", c.chamfer)),
                                         fmt::arg("dock", walled_hole(c.dock_half, PlugEnv::kDockWallThick, PlugEnv::kDockWallHeight, "dark")), fmt::arg("hh", c.handle_half),
                                         fmt::arg("hz", kHandleHalfZ), fmt::arg("pz2", kHandleHalfZ + kProngHalfZ),
                                         fmt::arg("ph", c.prong_half), fmt::arg("pz", kProngHalfZ));
  return arm_scene_xml("plug", Tool::kGripper, c.camera_size, side_cameras_xml() + overview_camera_xml(), bodies);
}

PlugEnv::PlugEnv(PlugConfig config)
    : ArmEnv("plug", plug_xml(config), Tool::kGripper, ArmControl::kEndEffectorPose, config.time_limit), config_(config) {
  charger_ = id(model(), mjOBJ_BODY, "charger");
  receptacle_ = model()->body_mocapid[id(model(), mjOBJ_BODY, "receptacle")];
  dock_ = model()->body_mocapid[id(model(), mjOBJ_BODY, "dock")];
  reset(0);
}

void PlugEnv::reset(uint64_t seed) {
  reset_arm();
  std::mt19937_64 rng(seed * 0x9E3779B97F4A7C15ull + 23);
  std::uniform_real_distribution<double> u(0, 1);
  mjData* d = mutable_data();
  const Eigen::Vector2d dock(0.42 + 0.18 * u(rng), -0.22 + 0.14 * u(rng));
  const Eigen::Vector2d socket(0.45 + 0.15 * u(rng), 0.08 + 0.14 * u(rng));
  const double dock_yaw = (u(rng) - 0.5) * 0.6;
  socket_yaw_ = (u(rng) - 0.5) * 0.6;
  auto place = [&](int mocap, const Eigen::Vector2d& p, double yaw) {
    d->mocap_pos[3 * mocap] = p.x();
    d->mocap_pos[3 * mocap + 1] = p.y();
    d->mocap_pos[3 * mocap + 2] = 0;
    d->mocap_quat[4 * mocap] = std::cos(yaw / 2);
    d->mocap_quat[4 * mocap + 1] = 0;
    d->mocap_quat[4 * mocap + 2] = 0;
    d->mocap_quat[4 * mocap + 3] = std::sin(yaw / 2);
  };
  place(receptacle_, socket, socket_yaw_);
  place(dock_, dock, dock_yaw);
  const double charger_yaw = dock_yaw + (u(rng) - 0.5) * 0.2;
  set_free_pose(model(), d, charger_, {dock.x(), dock.y(), 2 * kProngHalfZ + kHandleHalfZ + 0.001},
                Eigen::Quaterniond(Eigen::AngleAxisd(charger_yaw, Eigen::Vector3d::UnitZ())));
  mj_forward(model(), d);
}

Eigen::Vector3d PlugEnv::socket_pos() const {
  const double* p = data()->mocap_pos + 3 * receptacle_;
  return {p[0], p[1], p[2]};
}

Eigen::Vector3d PlugEnv::dock_pos() const {
  const double* p = data()->mocap_pos + 3 * dock_;
  return {p[0], p[1], p[2]};
}

double PlugEnv::seated_height() const { return kWall + kHandleHalfZ; }

double PlugEnv::charger_yaw() const {
  const Eigen::Vector3d x = free_quat(model(), data(), charger_).toRotationMatrix().col(0);
  return std::atan2(x.y(), x.x());
}

bool PlugEnv::inserted() const {
  const Eigen::Vector3d c = charger_pos(), s = socket_pos();
  return (c.head<2>() - s.head<2>()).norm() < 0.002 && c.z() < seated_height() + 0.003 && charger_tilt() < 10 * M_PI / 180;
}

double PlugEnv::charger_tilt() const {
  const Eigen::Vector3d z = free_quat(model(), data(), charger_).toRotationMatrix().col(2);
  return std::acos(std::clamp(z.z(), -1.0, 1.0));
}

bool PlugEnv::toppled() const {
  const Eigen::Matrix<double, 6, 1> v = free_vel(model(), data(), charger_);
  return charger_tilt() > kToppled && v.head<3>().norm() < 0.02 && v.tail<3>().norm() < 0.5;
}

std::string PlugEnv::outcome() const {
  if (success()) return "success";
  if (charger_tilt() > kToppled) return "toppled";
  const Eigen::Vector3d c = charger_pos();
  if ((c.head<2>() - socket_pos().head<2>()).norm() < 0.01) return "over the socket";
  if ((arm().tcp_pos(data()) - c).norm() < 0.04 && c.z() > seated_height() + 0.01) return "held";
  if ((c.head<2>() - dock_pos().head<2>()).norm() < 0.01) return "in the dock";
  return "dropped";
}

Vec PlugEnv::observation() const {
  Vec o(37);
  int k = 0;
  arm_observation(o, k);
  const Eigen::Vector3d p = charger_pos();
  const Eigen::Quaterniond q = free_quat(model(), data(), charger_);
  for (int i = 0; i < 3; ++i) o[k++] = static_cast<float>(p[i]);
  o[k++] = static_cast<float>(q.w());
  o[k++] = static_cast<float>(q.x());
  o[k++] = static_cast<float>(q.y());
  o[k++] = static_cast<float>(q.z());
  const Eigen::Vector3d s = socket_pos();
  for (int i = 0; i < 3; ++i) o[k++] = static_cast<float>(s[i]);
  const double* mq = data()->mocap_quat + 4 * receptacle_;
  for (int i = 0; i < 4; ++i) o[k++] = static_cast<float>(mq[i]);
  const Eigen::Vector3d tcp = arm().tcp_pos(data());
  for (int i = 0; i < 3; ++i) o[k++] = static_cast<float>(p[i] - tcp[i]);  // charger minus TCP
  for (int i = 0; i < 3; ++i) o[k++] = static_cast<float>(s[i] - p[i]);    // socket minus charger
  return o;
}

}  // namespace dd::mj
