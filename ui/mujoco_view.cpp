#include "ui/mujoco_view.h"

#include <GL/gl.h>
#include <GL/glext.h>
#include <mujoco/mujoco.h>

#include <algorithm>

#include "core/config.h"
#include "ui/headless_gl.h"

namespace dd::ui {

struct MujocoView::Impl {
  const mjModel* model;
  mjvScene scene;
  mjrContext context;
  mjvOption option;
};

MujocoView::MujocoView(const mjModel* model) : impl_(std::make_unique<Impl>()) {
  impl_->model = model;
  mjv_defaultScene(&impl_->scene);
  mjr_defaultContext(&impl_->context);
  mjv_defaultOption(&impl_->option);
  mjv_makeScene(model, &impl_->scene, 2000);
  GLint previous_draw = 0, previous_read = 0;
  glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &previous_draw);
  glGetIntegerv(GL_READ_FRAMEBUFFER_BINDING, &previous_read);
  mjr_makeContext(model, &impl_->context, mjFONTSCALE_100);
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, static_cast<GLuint>(previous_draw));
  glBindFramebuffer(GL_READ_FRAMEBUFFER, static_cast<GLuint>(previous_read));
  if (!impl_->context.offFBO) throw Error("MuJoCo could not make its offscreen framebuffer (needs a compatibility-profile GL context)");
}

MujocoView::~MujocoView() {
  mjr_freeContext(&impl_->context);
  mjv_freeScene(&impl_->scene);
}

std::vector<std::string> MujocoView::camera_names() const {
  std::vector<std::string> out;
  for (int i = 0; i < impl_->model->ncam; ++i) out.emplace_back(mj_id2name(impl_->model, mjOBJ_CAMERA, i));
  return out;
}

Image MujocoView::camera(const mjData* data, const std::string& name, int width, int height, bool cheap) {
  const int id = mj_name2id(impl_->model, mjOBJ_CAMERA, name.c_str());
  if (id < 0) throw Error("MuJoCo scene: no camera named '" + name + "'");
  return render(data, id, nullptr, width, height, cheap);
}

Image MujocoView::free(const mjData* data, const FreeCamera& cam, int width, int height, const std::vector<Marker>& markers) {
  return render(data, -1, &cam, width, height, false, markers);
}

Image MujocoView::camera_view(const mjData* data, const std::string& name, int width, int height, const std::vector<Marker>& markers) {
  const int id = mj_name2id(impl_->model, mjOBJ_CAMERA, name.c_str());
  if (id < 0) throw Error("MuJoCo scene: no camera named '" + name + "'");
  return render(data, id, nullptr, width, height, false, markers);
}

bool MujocoView::select(const mjData* data, double relx, double rely, double aspect, double point[3]) {
  int geom = -1, skin = -1;
  mjtNum p[3];
  const int body = mjv_select(impl_->model, data, &impl_->option, aspect, relx, rely, &impl_->scene, p, &geom, &skin);
  if (body < 0 && geom < 0) return false;
  for (int i = 0; i < 3; ++i) point[i] = p[i];
  return true;
}

Image MujocoView::render(const mjData* data, int camera_id, const FreeCamera* fc, int width, int height, bool cheap,
                         const std::vector<Marker>& markers) {
  Impl& s = *impl_;
  width = std::min(width, s.context.offWidth);
  height = std::min(height, s.context.offHeight);
  mjvCamera cam;
  mjv_defaultCamera(&cam);
  if (camera_id >= 0) {
    cam.type = mjCAMERA_FIXED;
    cam.fixedcamid = camera_id;
  } else {
    cam.type = mjCAMERA_FREE;
    std::copy(fc->lookat, fc->lookat + 3, cam.lookat);
    cam.distance = fc->distance;
    cam.azimuth = fc->azimuth;
    cam.elevation = fc->elevation;
  }
  s.scene.flags[mjRND_SHADOW] = cheap ? 0 : 1;
  s.scene.flags[mjRND_REFLECTION] = cheap ? 0 : 1;
  s.scene.flags[mjRND_SKYBOX] = 1;
  mjv_updateScene(s.model, const_cast<mjData*>(data), &s.option, nullptr, &cam, mjCAT_ALL, &s.scene);
  for (const Marker& m : markers) {
    if (s.scene.ngeom >= s.scene.maxgeom) break;
    mjvGeom* g = s.scene.geoms + s.scene.ngeom++;
    const mjtNum size[3] = {m.radius, m.radius, m.radius};
    mjv_initGeom(g, mjGEOM_SPHERE, size, m.pos, nullptr, m.rgba);
    g->category = mjCAT_DECOR;
  }
  // MuJoCo binds its own framebuffers: put the caller's back afterwards (a window's, or HeadlessGL's)
  GLint previous_draw = 0, previous_read = 0, viewport_before[4];
  glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &previous_draw);
  glGetIntegerv(GL_READ_FRAMEBUFFER_BINDING, &previous_read);
  glGetIntegerv(GL_VIEWPORT, viewport_before);
  mjr_setBuffer(mjFB_OFFSCREEN, &s.context);
  const mjrRect viewport{0, 0, width, height};
  mjr_render(viewport, &s.scene, &s.context);
  std::vector<unsigned char> rgb(static_cast<size_t>(width) * height * 3);
  mjr_readPixels(rgb.data(), nullptr, viewport, &s.context);
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, static_cast<GLuint>(previous_draw));
  glBindFramebuffer(GL_READ_FRAMEBUFFER, static_cast<GLuint>(previous_read));
  glViewport(viewport_before[0], viewport_before[1], viewport_before[2], viewport_before[3]);
  Image img{width, height, std::vector<uint8_t>(static_cast<size_t>(width) * height * 4)};
  for (int y = 0; y < height; ++y)  // MuJoCo's rows are bottom-up; the sky's alpha is 0, so write 255
    for (int x = 0; x < width; ++x) {
      const size_t src = (static_cast<size_t>(height - 1 - y) * width + x) * 3, dst = (static_cast<size_t>(y) * width + x) * 4;
      img.rgba[dst] = rgb[src];
      img.rgba[dst + 1] = rgb[src + 1];
      img.rgba[dst + 2] = rgb[src + 2];
      img.rgba[dst + 3] = 255;
    }
  return img;
}

std::vector<std::pair<std::string, Image>> render_all_cameras(const mjModel* model, const mjData* data, int size) {
  std::string error;
  auto gl = HeadlessGL::create(64, 64, &error);
  if (!gl) throw Error(error);
  MujocoView view(model);
  std::vector<std::pair<std::string, Image>> out;
  for (const std::string& name : view.camera_names()) out.emplace_back(name, view.camera(data, name, size, size, true));
  return out;
}

}  // namespace dd::ui
