// The 2-D toy's scene, drawn with the project's GLSL shaders (shaders/scene2d.*, heatmap.frag) into an
// offscreen texture that the console shows as an image. Shapes are queued in world coordinates
// (metres) between begin() and render(); edges are anti-aliased in the fragment shader.
//
// Needs a current OpenGL (compatibility or 3.0+) context on the calling thread.
#pragma once

#include <array>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace dd::ui {

using Rgba = std::array<float, 4>;

class Scene2d {
 public:
  /// Compiles the shaders and makes a width x height render target. Returns nullptr and fills
  /// `error` (with the shader log) on failure.
  static std::unique_ptr<Scene2d> create(int width, int height, std::string* error);
  ~Scene2d();
  Scene2d(const Scene2d&) = delete;
  Scene2d& operator=(const Scene2d&) = delete;

  void resize(int width, int height);
  int width() const { return width_; }
  int height() const { return height_; }

  /// Starts a frame showing the world square centred at `center` with half-width `half` (the
  /// shorter side of the target sees exactly that much).
  void begin(const Eigen::Vector2d& center, double half, const Rgba& background);
  void rect(const Eigen::Vector2d& lo, const Eigen::Vector2d& hi, const Rgba& color);
  /// A disc of world radius r; `rim` darkens the outer fraction of the radius.
  void disc(const Eigen::Vector2d& c, double r, const Rgba& color, float rim = 0.f);
  /// A disc of a fixed size in pixels (markers).
  void dot(const Eigen::Vector2d& c, double radius_px, const Rgba& color);
  /// A polyline of a fixed width in pixels.
  void stroke(const std::vector<Eigen::Vector2d>& points, double width_px, const Rgba& color);
  /// A ring (circle outline) of world radius r and pixel width.
  void ring(const Eigen::Vector2d& c, double r, double width_px, const Rgba& color);
  /// The heat map behind the shapes: nx x ny values in [0, 1] (row-major, y up) covering [lo, hi].
  void heat(const std::vector<float>& values, int nx, int ny, const Eigen::Vector2d& lo, const Eigen::Vector2d& hi,
            float alpha);
  /// Draws everything queued into the texture (restores the caller's framebuffer and viewport).
  void render();

  /// The colour texture (GL name) of the last render, bottom row first.
  unsigned texture() const { return color_; }
  /// World position of a pixel of the texture (x right, y down from the top-left corner).
  Eigen::Vector2d pixel_to_world(double px, double py) const;

 private:
  Scene2d() = default;
  struct Vertex {
    float x, y, u, v, r, g, b, a;
  };
  struct Batch {
    int mode;
    float rim;
    size_t first, count;
  };
  void push_quad(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c, const Eigen::Vector2d& d,
                 const Rgba& color, int mode, float rim, const std::array<float, 8>& local);
  double pixel_size() const;

  int width_ = 0, height_ = 0;
  unsigned fbo_ = 0, color_ = 0, program_ = 0, heat_program_ = 0, vao_ = 0, vbo_ = 0, heat_tex_ = 0;
  Eigen::Vector2d center_{0, 0};
  double half_ = 1, sx_ = 1, sy_ = 1;
  Rgba background_{0, 0, 0, 1};
  std::vector<Vertex> vertices_;
  std::vector<Batch> batches_;
  bool heat_on_ = false;
  float heat_alpha_ = 1.f;
  Eigen::Vector2d heat_lo_{0, 0}, heat_hi_{0, 0};
};

}  // namespace dd::ui
