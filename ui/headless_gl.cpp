#include "ui/headless_gl.h"

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GL/gl.h>
#include <GL/glext.h>

#include <cstring>

namespace dd::ui {

struct HeadlessGL::Egl {
  EGLDisplay display = EGL_NO_DISPLAY;
  EGLContext context = EGL_NO_CONTEXT;
};

namespace {

std::string egl_error(const char* what) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "%s failed (EGL error 0x%04x)", what, eglGetError());
  return buf;
}

// The surfaceless Mesa platform works without a display; the device platform is the fallback.
EGLDisplay open_display() {
  auto get_platform_display =
      reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
  if (!get_platform_display) return EGL_NO_DISPLAY;
  EGLDisplay d = get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
  if (d != EGL_NO_DISPLAY && eglInitialize(d, nullptr, nullptr)) return d;
  auto query_devices = reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
  if (!query_devices) return EGL_NO_DISPLAY;
  EGLDeviceEXT devices[8];
  EGLint n = 0;
  if (!query_devices(8, devices, &n)) return EGL_NO_DISPLAY;
  for (EGLint i = 0; i < n; ++i) {
    d = get_platform_display(EGL_PLATFORM_DEVICE_EXT, devices[i], nullptr);
    if (d != EGL_NO_DISPLAY && eglInitialize(d, nullptr, nullptr)) return d;
  }
  return EGL_NO_DISPLAY;
}

}  // namespace

std::unique_ptr<HeadlessGL> HeadlessGL::create(int width, int height, std::string* error) {
  auto fail = [&](std::string msg) -> std::unique_ptr<HeadlessGL> {
    if (error) *error = "headless GL: " + msg;
    return nullptr;
  };
  if (width <= 0 || height <= 0) return fail("width and height must be positive");
  std::unique_ptr<HeadlessGL> gl(new HeadlessGL());
  gl->egl_ = std::make_unique<Egl>();
  Egl& e = *gl->egl_;
  e.display = open_display();
  if (e.display == EGL_NO_DISPLAY) return fail("no EGL display (is Mesa's libegl-mesa0 installed?)");
  const EGLint config_attribs[] = {EGL_SURFACE_TYPE, 0, EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
  EGLConfig config;
  EGLint n = 0;
  if (!eglChooseConfig(e.display, config_attribs, &config, 1, &n) || n < 1) return fail(egl_error("eglChooseConfig"));
  if (!eglBindAPI(EGL_OPENGL_API)) return fail(egl_error("eglBindAPI"));
  const EGLint ctx_attribs[] = {EGL_CONTEXT_OPENGL_PROFILE_MASK, EGL_CONTEXT_OPENGL_COMPATIBILITY_PROFILE_BIT, EGL_NONE};
  e.context = eglCreateContext(e.display, config, EGL_NO_CONTEXT, ctx_attribs);
  if (e.context == EGL_NO_CONTEXT) return fail(egl_error("eglCreateContext"));
  if (!eglMakeCurrent(e.display, EGL_NO_SURFACE, EGL_NO_SURFACE, e.context)) return fail(egl_error("eglMakeCurrent"));

  gl->width_ = width;
  gl->height_ = height;
  glGenFramebuffers(1, &gl->fbo_);
  glBindFramebuffer(GL_FRAMEBUFFER, gl->fbo_);
  glGenRenderbuffers(1, &gl->color_);
  glBindRenderbuffer(GL_RENDERBUFFER, gl->color_);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, width, height);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, gl->color_);
  glGenRenderbuffers(1, &gl->depth_);
  glBindRenderbuffer(GL_RENDERBUFFER, gl->depth_);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH24_STENCIL8, width, height);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_STENCIL_ATTACHMENT, GL_RENDERBUFFER, gl->depth_);
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) return fail("offscreen framebuffer incomplete");
  glViewport(0, 0, width, height);
  return gl;
}

HeadlessGL::~HeadlessGL() {
  if (!egl_ || egl_->display == EGL_NO_DISPLAY) return;
  if (egl_->context != EGL_NO_CONTEXT) {
    eglMakeCurrent(egl_->display, EGL_NO_SURFACE, EGL_NO_SURFACE, egl_->context);
    if (fbo_) glDeleteFramebuffers(1, &fbo_);
    if (color_) glDeleteRenderbuffers(1, &color_);
    if (depth_) glDeleteRenderbuffers(1, &depth_);
    eglMakeCurrent(egl_->display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    eglDestroyContext(egl_->display, egl_->context);
  }
  eglTerminate(egl_->display);
}

void HeadlessGL::make_current() {
  eglMakeCurrent(egl_->display, EGL_NO_SURFACE, EGL_NO_SURFACE, egl_->context);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
}

std::vector<uint8_t> read_framebuffer_rgba(int width, int height) {
  std::vector<uint8_t> pixels(static_cast<size_t>(width) * height * 4);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadPixels(0, 0, width, height, GL_RGBA, GL_UNSIGNED_BYTE, pixels.data());
  // GL rows run bottom-up; flip to the usual top-down order.
  const size_t row = static_cast<size_t>(width) * 4;
  std::vector<uint8_t> tmp(row);
  for (int y = 0; y < height / 2; ++y) {
    uint8_t* a = pixels.data() + y * row;
    uint8_t* b = pixels.data() + (height - 1 - y) * row;
    std::memcpy(tmp.data(), a, row);
    std::memcpy(a, b, row);
    std::memcpy(b, tmp.data(), row);
  }
  return pixels;
}

std::vector<uint8_t> HeadlessGL::read_rgba() const {
  glBindFramebuffer(GL_READ_FRAMEBUFFER, fbo_);
  return read_framebuffer_rgba(width_, height_);
}

std::string HeadlessGL::renderer() const {
  const auto* s = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  return s ? s : "";
}

}  // namespace dd::ui
