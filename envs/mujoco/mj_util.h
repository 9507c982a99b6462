// MuJoCo plumbing shared by the manipulation tasks: loading MJCF text from memory, turning MuJoCo's
// fatal errors into exceptions, owning model and data, and small pose helpers (6-D rotations).
#pragma once

#include <mujoco/mujoco.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <memory>
#include <string>

namespace dd::mj {

struct ModelDeleter {
  void operator()(mjModel* m) const { mj_deleteModel(m); }
};
struct DataDeleter {
  void operator()(mjData* d) const { mj_deleteData(d); }
};
using ModelPtr = std::unique_ptr<mjModel, ModelDeleter>;
using DataPtr = std::unique_ptr<mjData, DataDeleter>;

/// Installs handlers so that MuJoCo's errors throw dd::Error and its warnings are logged, instead
/// of printing and calling exit(). Idempotent.
void install_error_handlers();

/// Compiles MJCF text (no files are read). Throws dd::Error with MuJoCo's message and `name`.
ModelPtr load_xml(const std::string& xml, const std::string& name);

/// A body's or site's id; throws dd::Error naming the model and the element when missing.
int id(const mjModel* m, mjtObj type, const std::string& name);

/// 6-D rotation (the first two columns of the rotation matrix, Zhou et al.) and back (Gram-Schmidt).
Eigen::Matrix<double, 6, 1> rot6d(const Eigen::Matrix3d& R);
Eigen::Matrix3d from_rot6d(const Eigen::Matrix<double, 6, 1>& r);

/// A site's position and rotation in the world.
Eigen::Vector3d site_pos(const mjModel* m, const mjData* d, int site);
Eigen::Matrix3d site_rot(const mjModel* m, const mjData* d, int site);

/// A free body's position and quaternion (w, x, y, z) from qpos.
Eigen::Vector3d free_pos(const mjModel* m, const mjData* d, int body);
Eigen::Quaterniond free_quat(const mjModel* m, const mjData* d, int body);
/// Places a free body at rest.
void set_free_pose(const mjModel* m, mjData* d, int body, const Eigen::Vector3d& p, const Eigen::Quaterniond& q);
/// A free body's velocity from qvel: linear (world frame), then angular (body frame), as MuJoCo keeps it.
Eigen::Matrix<double, 6, 1> free_vel(const mjModel* m, const mjData* d, int body);
void set_free_vel(const mjModel* m, mjData* d, int body, const Eigen::Matrix<double, 6, 1>& v);

/// True if every entry of qpos and qvel is finite and MuJoCo raised no instability warning.
bool state_ok(const mjModel* m, const mjData* d);

}  // namespace dd::mj
