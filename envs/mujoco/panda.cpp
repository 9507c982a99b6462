#include "envs/mujoco/panda.h"

#include <fmt/format.h>

#include <Eigen/Dense>
#include <cmath>

namespace dd::mj {
namespace {

// Modified DH (Craig): joint i's frame = RotX(alpha_{i-1}) TransX(a_{i-1}) TransZ(d_i) RotZ(q_i).
struct Dh {
  double a, d, alpha;
};
constexpr Dh kDh[7] = {{0, 0.333, 0},          {0, 0, -M_PI / 2},      {0, 0.316, M_PI / 2}, {0.0825, 0, M_PI / 2},
                       {-0.0825, 0.384, -M_PI / 2}, {0, 0, M_PI / 2}, {0.088, 0, M_PI / 2}};
constexpr double kFlange = 0.107;  // flange offset along joint 7's axis
constexpr double kTcp = 0.1034;    // gripper TCP below the flange
constexpr double kStick = 0.16;    // stick tip below the flange

std::string frame(const Dh& p) {
  const double px = p.a, py = -std::sin(p.alpha) * p.d, pz = std::cos(p.alpha) * p.d;
  return fmt::format(R"(pos="{:.6g} {:.6g} {:.6g}" quat="{:.9g} {:.9g} 0 0")", px, py, pz, std::cos(p.alpha / 2),
                     std::sin(p.alpha / 2));
}

// Where the next joint's frame sits in this link's frame (for the link's capsule).
Eigen::Vector3d next_origin(int i) {
  if (i == 6) return {0, 0, kFlange};
  const Dh& p = kDh[i + 1];
  return {p.a, -std::sin(p.alpha) * p.d, std::cos(p.alpha) * p.d};
}

}  // namespace

Vec7 panda_lower() { return (Vec7() << -2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973).finished(); }
Vec7 panda_upper() { return (Vec7() << 2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973).finished(); }
Vec7 panda_home() { return (Vec7() << 0, -0.35, 0, -2.3, 0, 1.95, M_PI / 4).finished(); }

namespace {

std::string scene_common_xml(int w, int h) {
  return fmt::format(R"(
  <compiler angle="radian"/>
  <option timestep="0.002" cone="elliptic" impratio="10"/>
  <visual>
    <global offwidth="{}" offheight="{}"/>
    <quality shadowsize="2048"/>
    <headlight ambient="0.35 0.35 0.35" diffuse="0.5 0.5 0.5" specular="0.1 0.1 0.1"/>
  </visual>
  <default>
    <joint armature="0.1" damping="1"/>
    <geom solref="0.004 1" solimp="0.95 0.99 0.001" friction="1 0.005 0.0001"/>
    <default class="visual"><geom contype="0" conaffinity="0" group="1"/></default>
  </default>
  <asset>
    <texture name="sky" type="skybox" builtin="gradient" rgb1="0.32 0.36 0.42" rgb2="0.08 0.09 0.11" width="64" height="64"/>
    <texture name="floor" type="2d" builtin="checker" rgb1="0.22 0.23 0.26" rgb2="0.18 0.19 0.21" width="256" height="256"/>
    <material name="floor" texture="floor" texrepeat="8 8"/>
    <material name="table" rgba="0.62 0.52 0.42 1"/>
    <material name="white" rgba="0.93 0.93 0.94 1"/>
    <material name="dark" rgba="0.18 0.19 0.21 1"/>
    <material name="red" rgba="0.85 0.18 0.16 1"/>
    <material name="green" rgba="0.20 0.72 0.30 1"/>
    <material name="blue" rgba="0.22 0.45 0.85 1"/>
    <material name="goal" rgba="0.30 0.85 0.40 0.35"/>
  </asset>
)",
                     w, h);
}

std::string room_xml() {
  return R"(    <light pos="0.4 -0.6 1.6" dir="0 0.35 -1" diffuse="0.7 0.7 0.7" castshadow="true"/>
    <light pos="0.4 0.8 1.4" dir="0 -0.5 -1" diffuse="0.3 0.3 0.3" castshadow="false"/>
    <geom name="floor" type="plane" size="3 3 0.1" pos="0 0 -0.75" material="floor"/>
    <geom name="table" type="box" size="0.45 0.6 0.375" pos="0.45 0 -0.375" material="table"/>)";
}

std::string panda_body_xml(Tool tool, const Eigen::Vector3d& base) {
  std::string x = fmt::format(R"(<body name="link0" pos="{} {} {}">
  <geom class="visual" type="cylinder" size="0.07 0.03" pos="0 0 0.03" material="dark"/>
  <geom class="visual" type="capsule" fromto="0 0 0.03 0 0 0.27" size="0.06" material="white"/>
)",
                              base.x(), base.y(), base.z());
  const double radius[7] = {0.06, 0.06, 0.055, 0.055, 0.05, 0.045, 0.04};
  const double mass[7] = {3.0, 3.0, 2.5, 2.5, 2.0, 1.5, 0.6};
  const std::string limits[7] = {"-2.8973 2.8973", "-1.7628 1.7628", "-2.8973 2.8973", "-3.0718 -0.0698",
                                 "-2.8973 2.8973", "-0.0175 3.7525", "-2.8973 2.8973"};
  for (int i = 0; i < 7; ++i) {
    const Eigen::Vector3d n = next_origin(i);
    x += fmt::format(R"(<body name="link{}" {}>
  <inertial pos="{} {} {}" mass="{}" diaginertia="0.02 0.02 0.01"/>
  <joint name="j{}" axis="0 0 1" limited="true" range="{}"/>
  <geom class="visual" type="sphere" size="{}" material="{}"/>
)",
                     i + 1, frame(kDh[i]), n.x() / 2, n.y() / 2, n.z() / 2, mass[i], i + 1, limits[i], radius[i] * 1.18,
                     i % 2 ? "dark" : "white");
    if (n.norm() > 1e-6)
      x += fmt::format(R"(  <geom class="visual" type="capsule" fromto="0 0 0 {} {} {}" size="{}" material="white"/>
)",
                       n.x(), n.y(), n.z(), radius[i]);
  }
  // the hand, turned -45 degrees about the flange axis like the Panda's
  x += fmt::format(R"(<body name="hand" pos="0 0 {}" quat="0.9238795 0 0 -0.3826834">
  <inertial pos="0 0 0.03" mass="0.7" diaginertia="0.003 0.003 0.002"/>
  <camera name="wrist" pos="0.07 0 0.02" xyaxes="0 1 0 0.954 0 0.301" fovy="75"/>
)",
                   kFlange);
  if (tool == Tool::kGripper) {
    x += fmt::format(R"(  <geom type="box" size="0.025 0.095 0.03" pos="0 0 0.03" material="white"/>
  <site name="tcp" pos="0 0 {}" size="0.006" rgba="1 0.5 0 0.6" group="2"/>
)",
                     kTcp);
    // the two fingers mirror each other across the hand's x-z plane; each slides outwards along +-y
    for (const auto& [name, sign] : {std::pair<const char*, int>{"left", 1}, {"right", -1}})
      x += fmt::format(R"(  <body name="finger_{0}" pos="0 0 0.0584">
    <inertial pos="0 {1} 0.03" mass="0.05" diaginertia="1e-5 1e-5 1e-5"/>
    <joint name="finger_{0}" type="slide" axis="0 {2} 0" limited="true" range="0 0.04" damping="5" armature="0.01"/>
    <geom type="box" size="0.01 0.006 0.028" pos="0 {3} 0.018" material="dark"/>
    <geom name="pad_{0}" type="box" size="0.01 0.004 0.012" pos="0 {4} 0.042" material="dark" friction="1.5 0.01 0.0005"/>
  </body>
)",
                       name, 0.01 * sign, sign, 0.016 * sign, 0.004 * sign);
  } else {
    x += fmt::format(R"(  <geom type="box" size="0.025 0.06 0.03" pos="0 0 0.03" material="white"/>
  <geom name="stick" type="capsule" fromto="0 0 0.05 0 0 {}" size="0.012" material="dark"/>
  <site name="tcp" pos="0 0 {}" size="0.006" rgba="1 0.5 0 0.6" group="2"/>
)",
                     kStick, kStick);
  }
  x += "</body>\n";
  for (int i = 0; i < 7; ++i) x += "</body>\n";
  x += "</body>\n";
  return x;
}

std::string panda_actuator_xml(Tool tool) {
  const double kp[7] = {800, 800, 600, 600, 300, 200, 80};
  const double kv[7] = {60, 60, 45, 45, 20, 15, 6};
  const double force[7] = {87, 87, 87, 87, 12, 12, 12};
  std::string x;
  for (int i = 0; i < 7; ++i)
    x += fmt::format(R"(  <general name="a{}" joint="j{}" gainprm="{}" biastype="affine" biasprm="0 -{} -{}" forcelimited="true" forcerange="-{} {}"/>
)",
                     i + 1, i + 1, kp[i], kp[i], kv[i], force[i], force[i]);
  if (tool == Tool::kGripper) {
    x += R"(  <position name="grip_left" joint="finger_left" kp="400" forcelimited="true" forcerange="-25 25"/>
  <position name="grip_right" joint="finger_right" kp="400" forcelimited="true" forcerange="-25 25"/>
)";
  }
  return x;
}

}  // namespace

std::string side_cameras_xml() {
  return R"(    <camera name="left" pos="0.5 -0.95 0.55" xyaxes="1 0 0 0 0.447 0.894" fovy="55"/>
    <camera name="right" pos="0.5 0.95 0.55" xyaxes="-1 0 0 0 -0.447 0.894" fovy="55"/>
)";
}

std::string overview_camera_xml() {
  return R"(    <camera name="overview" pos="1.45 -0.75 0.85" xyaxes="0.46 0.89 0 -0.45 0.23 0.86" fovy="45"/>)";
}

std::string arm_scene_xml(const std::string& model, Tool tool, int camera_size, const std::string& cameras,
                          const std::string& bodies) {
  const int buffer = std::max(640, camera_size);
  return fmt::format(R"(<mujoco model="{}">{}
  <worldbody>
{}
{}
{}{}  </worldbody>
  <actuator>
{}  </actuator>
</mujoco>
)",
                     model, scene_common_xml(buffer, buffer), room_xml(), cameras, panda_body_xml(tool, {0, 0, 0}), bodies,
                     panda_actuator_xml(tool));
}

PandaArm::PandaArm(const mjModel* m, Tool tool) : tool_(tool) {
  tcp_ = id(m, mjOBJ_SITE, "tcp");
  for (int i = 0; i < 7; ++i) {
    const int j = id(m, mjOBJ_JOINT, "j" + std::to_string(i + 1));
    qadr_[i] = m->jnt_qposadr[j];
    vadr_[i] = m->jnt_dofadr[j];
    act_[i] = id(m, mjOBJ_ACTUATOR, "a" + std::to_string(i + 1));
  }
  if (tool == Tool::kGripper) {
    finger_qadr_[0] = m->jnt_qposadr[id(m, mjOBJ_JOINT, "finger_left")];
    finger_qadr_[1] = m->jnt_qposadr[id(m, mjOBJ_JOINT, "finger_right")];
    finger_act_[0] = id(m, mjOBJ_ACTUATOR, "grip_left");
    finger_act_[1] = id(m, mjOBJ_ACTUATOR, "grip_right");
  }
}

Vec7 PandaArm::q(const mjData* d) const {
  Vec7 q;
  for (int i = 0; i < 7; ++i) q[i] = d->qpos[qadr_[i]];
  return q;
}

Eigen::Vector3d PandaArm::tcp_pos(const mjData* d) const { return site_pos(nullptr, d, tcp_); }
Eigen::Matrix3d PandaArm::tcp_rot(const mjData* d) const { return site_rot(nullptr, d, tcp_); }

double PandaArm::opening(const mjData* d) const {
  if (tool_ != Tool::kGripper) return 0;
  return d->qpos[finger_qadr_[0]] + d->qpos[finger_qadr_[1]];
}

void PandaArm::set_posture(mjData* d, const Vec7& q) const {
  for (int i = 0; i < 7; ++i) {
    d->qpos[qadr_[i]] = q[i];
    d->qvel[vadr_[i]] = 0;
    d->ctrl[act_[i]] = q[i];
  }
  if (tool_ == Tool::kGripper)
    for (int f = 0; f < 2; ++f) {
      d->qpos[finger_qadr_[f]] = 0.04;
      d->ctrl[finger_act_[f]] = 0.04;
    }
}

Vec7 PandaArm::ik(const mjModel* m, const mjData* d, mjData* s, const Eigen::Vector3d& p, const Eigen::Matrix3d& R, int iterations,
                  double max_step) const {
  mju_copy(s->qpos, d->qpos, m->nq);
  const Vec7 q0 = q(d), lo = panda_lower(), hi = panda_upper(), home = panda_home();
  Vec7 qc = q0;
  Eigen::Matrix<double, 3, Eigen::Dynamic, Eigen::RowMajor> jp(3, m->nv), jr(3, m->nv);
  for (int it = 0; it < iterations; ++it) {
    mj_kinematics(m, s);
    mj_comPos(m, s);
    const Eigen::Vector3d pe = site_pos(m, s, tcp_);
    const Eigen::Matrix3d Re = site_rot(m, s, tcp_);
    Eigen::Matrix<double, 6, 1> e;
    e.head<3>() = p - pe;
    const Eigen::AngleAxisd aa(R * Re.transpose());
    e.tail<3>() = aa.angle() * aa.axis();
    if (e.head<3>().norm() < 1e-4 && e.tail<3>().norm() < 1e-3) break;
    mj_jacSite(m, s, jp.data(), jr.data(), tcp_);
    Eigen::Matrix<double, 6, 7> J;
    for (int i = 0; i < 7; ++i) {
      J.block<3, 1>(0, i) = jp.col(vadr_[i]);
      J.block<3, 1>(3, i) = jr.col(vadr_[i]);
    }
    const double lambda = e.head<3>().norm() > 0.03 ? 0.05 : 0.01;  // less damping close to the target
    const Eigen::Matrix<double, 6, 6> A = J * J.transpose() + lambda * lambda * Eigen::Matrix<double, 6, 6>::Identity();
    const Eigen::Matrix<double, 7, 6> Jp = J.transpose() * A.ldlt().solve(Eigen::Matrix<double, 6, 6>::Identity());
    Vec7 dq = Jp * e;
    const Eigen::Matrix<double, 7, 7> N = Eigen::Matrix<double, 7, 7>::Identity() - Jp * J;
    dq += N * (0.05 * (home - qc));
    qc = (qc + dq).cwiseMax(lo).cwiseMin(hi);
    for (int i = 0; i < 7; ++i) s->qpos[qadr_[i]] = qc[i];
  }
  return q0 + (qc - q0).cwiseMax(-max_step).cwiseMin(max_step);
}

void PandaArm::command(mjData* d, const Vec7& q_target, double grip) const {
  const Vec7 q = q_target.cwiseMax(panda_lower()).cwiseMin(panda_upper());
  for (int i = 0; i < 7; ++i) d->ctrl[act_[i]] = q[i];
  if (tool_ == Tool::kGripper) {
    const double target = 0.04 * (1.0 - std::clamp(grip, 0.0, 1.0));
    for (int f = 0; f < 2; ++f) d->ctrl[finger_act_[f]] = target;
  }
}

void PandaArm::compensate(const mjModel*, mjData* d) const {
  for (int i = 0; i < 7; ++i) d->qfrc_applied[vadr_[i]] = d->qfrc_bias[vadr_[i]];
}

}  // namespace dd::mj
