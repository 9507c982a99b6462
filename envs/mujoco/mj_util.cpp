#include "envs/mujoco/mj_util.h"

#include <spdlog/spdlog.h>

#include <cmath>
#include <cstring>
#include <mutex>

#include "core/config.h"

namespace dd::mj {
namespace {

void on_error(const char* msg) { throw Error(std::string("MuJoCo: ") + msg); }
void on_warning(const char* msg) { spdlog::debug("MuJoCo warning: {}", msg); }

}  // namespace

void install_error_handlers() {
  static std::once_flag once;
  std::call_once(once, [] {
    mju_user_error = on_error;
    mju_user_warning = on_warning;
  });
}

ModelPtr load_xml(const std::string& xml, const std::string& name) {
  install_error_handlers();
  auto vfs = std::make_unique<mjVFS>();
  mj_defaultVFS(vfs.get());
  const std::string file = name + ".xml";
  if (mj_makeEmptyFileVFS(vfs.get(), file.c_str(), static_cast<int>(xml.size())) != 0)
    throw Error(name + ": could not make a MuJoCo virtual file");
  const int i = mj_findFileVFS(vfs.get(), file.c_str());
  std::memcpy(vfs->filedata[i], xml.data(), xml.size());
  char error[1024] = "";
  mjModel* m = mj_loadXML(file.c_str(), vfs.get(), error, sizeof error);
  mj_deleteFileVFS(vfs.get(), file.c_str());
  if (!m) throw Error(name + ": MuJoCo could not load the model: " + error);
  return ModelPtr(m);
}

int id(const mjModel* m, mjtObj type, const std::string& name) {
  const int i = mj_name2id(m, type, name.c_str());
  if (i < 0) throw Error("MuJoCo model: no element named '" + name + "'");
  return i;
}

Eigen::Matrix<double, 6, 1> rot6d(const Eigen::Matrix3d& R) {
  Eigen::Matrix<double, 6, 1> r;
  r << R.col(0), R.col(1);
  return r;
}

Eigen::Matrix3d from_rot6d(const Eigen::Matrix<double, 6, 1>& r) {
  Eigen::Vector3d a = r.head<3>(), b = r.tail<3>();
  if (a.norm() < 1e-9) a = Eigen::Vector3d::UnitX();
  a.normalize();
  b -= a.dot(b) * a;
  if (b.norm() < 1e-9) b = a.unitOrthogonal();
  b.normalize();
  Eigen::Matrix3d R;
  R << a, b, a.cross(b);
  return R;
}

Eigen::Vector3d site_pos(const mjModel*, const mjData* d, int site) {
  return Eigen::Vector3d(d->site_xpos[3 * site], d->site_xpos[3 * site + 1], d->site_xpos[3 * site + 2]);
}

Eigen::Matrix3d site_rot(const mjModel*, const mjData* d, int site) {
  Eigen::Matrix3d R;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) R(r, c) = d->site_xmat[9 * site + 3 * r + c];
  return R;
}

Eigen::Vector3d free_pos(const mjModel* m, const mjData* d, int body) {
  const int a = m->jnt_qposadr[m->body_jntadr[body]];
  return Eigen::Vector3d(d->qpos[a], d->qpos[a + 1], d->qpos[a + 2]);
}

Eigen::Quaterniond free_quat(const mjModel* m, const mjData* d, int body) {
  const int a = m->jnt_qposadr[m->body_jntadr[body]];
  return Eigen::Quaterniond(d->qpos[a + 3], d->qpos[a + 4], d->qpos[a + 5], d->qpos[a + 6]);
}

void set_free_pose(const mjModel* m, mjData* d, int body, const Eigen::Vector3d& p, const Eigen::Quaterniond& q) {
  const int a = m->jnt_qposadr[m->body_jntadr[body]];
  for (int i = 0; i < 3; ++i) d->qpos[a + i] = p[i];
  d->qpos[a + 3] = q.w();
  d->qpos[a + 4] = q.x();
  d->qpos[a + 5] = q.y();
  d->qpos[a + 6] = q.z();
  set_free_vel(m, d, body, Eigen::Matrix<double, 6, 1>::Zero());
}

Eigen::Matrix<double, 6, 1> free_vel(const mjModel* m, const mjData* d, int body) {
  return Eigen::Map<const Eigen::Matrix<double, 6, 1>>(d->qvel + m->jnt_dofadr[m->body_jntadr[body]]);
}

void set_free_vel(const mjModel* m, mjData* d, int body, const Eigen::Matrix<double, 6, 1>& v) {
  Eigen::Map<Eigen::Matrix<double, 6, 1>>(d->qvel + m->jnt_dofadr[m->body_jntadr[body]]) = v;
}

bool state_ok(const mjModel* m, const mjData* d) {
  for (int i = 0; i < m->nq; ++i)
    if (!std::isfinite(d->qpos[i])) return false;
  for (int i = 0; i < m->nv; ++i)
    if (!std::isfinite(d->qvel[i]) || std::abs(d->qvel[i]) > 1e3) return false;
  return d->warning[mjWARN_BADQACC].number == 0;
}

}  // namespace dd::mj
