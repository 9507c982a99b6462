// A headless OpenGL context: EGL on Mesa's surfaceless platform (no display, no window), a
// compatibility-profile context (MuJoCo 2.2 needs one) and an offscreen framebuffer to draw into.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace dd::ui {

/// The current context's read framebuffer as RGBA8 rows, top row first (width * height * 4 bytes).
std::vector<uint8_t> read_framebuffer_rgba(int width, int height);

class HeadlessGL {
 public:
  /// Creates the context and a width x height RGBA8 framebuffer with depth, and makes both current.
  /// Returns nullptr and fills `error` when EGL or GL is not available.
  static std::unique_ptr<HeadlessGL> create(int width, int height, std::string* error);
  ~HeadlessGL();
  HeadlessGL(const HeadlessGL&) = delete;
  HeadlessGL& operator=(const HeadlessGL&) = delete;

  /// Makes this context and its framebuffer current on the calling thread.
  void make_current();
  /// Reads the framebuffer as RGBA8 rows, top row first (width * height * 4 bytes).
  std::vector<uint8_t> read_rgba() const;
  /// The GL_RENDERER string (e.g. "llvmpipe").
  std::string renderer() const;

  int width() const { return width_; }
  int height() const { return height_; }

 private:
  HeadlessGL() = default;
  struct Egl;
  std::unique_ptr<Egl> egl_;
  unsigned fbo_ = 0, color_ = 0, depth_ = 0;
  int width_ = 0, height_ = 0;
};

}  // namespace dd::ui
