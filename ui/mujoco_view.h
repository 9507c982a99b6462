// Rendering the MuJoCo scenes offscreen (EGL, no display): the task's named cameras for camera
// observations (small, cheap settings: no shadows, reflections or anti-aliasing), and a free camera
// for the console (pretty settings). The pixels come back top row first.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "ui/image_io.h"

struct mjModel_;
struct mjData_;

namespace dd::ui {

class HeadlessGL;

struct FreeCamera {
  double lookat[3] = {0.40, 0.0, 0.22};
  double distance = 1.9, azimuth = 140, elevation = -26;  // [m], [deg], [deg]
};

/// A sphere drawn into the scene (planned positions, the operator's target).
struct Marker {
  double pos[3];
  double radius;
  float rgba[4];
};

class MujocoView {
 public:
  /// Makes MuJoCo's GPU context for `model` on the calling thread's current GL context (a window's,
  /// or a HeadlessGL's). Throws dd::Error when MuJoCo cannot (e.g. a core-profile context).
  explicit MujocoView(const mjModel_* model);
  ~MujocoView();
  MujocoView(const MujocoView&) = delete;
  MujocoView& operator=(const MujocoView&) = delete;

  /// The camera's image, width x height RGBA (alpha 255); `cheap` turns off shadows, reflections
  /// and skybox detail. Throws dd::Error naming the camera when the model has none of that name.
  Image camera(const mjData_* data, const std::string& name, int width, int height, bool cheap = true);
  /// The scene from a free camera (the console's view), with markers.
  Image free(const mjData_* data, const FreeCamera& cam, int width, int height, const std::vector<Marker>& markers = {});
  /// A named camera with markers (pretty settings).
  Image camera_view(const mjData_* data, const std::string& name, int width, int height, const std::vector<Marker>& markers);
  /// The world point under (relx, rely) in [0, 1] (y up) of the last free-camera image; false when
  /// nothing is there.
  bool select(const mjData_* data, double relx, double rely, double aspect, double point[3]);
  /// Names of the model's cameras.
  std::vector<std::string> camera_names() const;

 private:
  Image render(const mjData_* data, int camera_id, const FreeCamera* cam, int width, int height, bool cheap,
               const std::vector<Marker>& markers = {});
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Renders every camera of `model` in state `data` at size x size through a private headless context.
/// Throws dd::Error when EGL is not available.
std::vector<std::pair<std::string, Image>> render_all_cameras(const mjModel_* model, const mjData_* data, int size);

}  // namespace dd::ui
