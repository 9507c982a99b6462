#include "ui/scene2d.h"

#include <GL/gl.h>
#include <GL/glext.h>

#include <cmath>

#include "shaders.h"

namespace dd::ui {
namespace {

unsigned compile(GLenum type, const char* source, const char* name, std::string* error) {
  const GLuint s = glCreateShader(type);
  glShaderSource(s, 1, &source, nullptr);
  glCompileShader(s);
  GLint ok = 0;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[2048];
    glGetShaderInfoLog(s, sizeof log, nullptr, log);
    if (error) *error = std::string("shaders/") + name + ": " + log;
    glDeleteShader(s);
    return 0;
  }
  return s;
}

unsigned link(const char* vert, const char* frag, const char* frag_name, std::string* error) {
  const unsigned vs = compile(GL_VERTEX_SHADER, vert, "scene2d.vert", error);
  if (!vs) return 0;
  const unsigned fs = compile(GL_FRAGMENT_SHADER, frag, frag_name, error);
  if (!fs) {
    glDeleteShader(vs);
    return 0;
  }
  const GLuint p = glCreateProgram();
  glAttachShader(p, vs);
  glAttachShader(p, fs);
  glBindAttribLocation(p, 0, "a_pos");
  glBindAttribLocation(p, 1, "a_local");
  glBindAttribLocation(p, 2, "a_color");
  glLinkProgram(p);
  glDeleteShader(vs);
  glDeleteShader(fs);
  GLint ok = 0;
  glGetProgramiv(p, GL_LINK_STATUS, &ok);
  if (!ok) {
    char log[2048];
    glGetProgramInfoLog(p, sizeof log, nullptr, log);
    if (error) *error = std::string("shaders/") + frag_name + " (link): " + log;
    glDeleteProgram(p);
    return 0;
  }
  return p;
}

}  // namespace

std::unique_ptr<Scene2d> Scene2d::create(int width, int height, std::string* error) {
  std::unique_ptr<Scene2d> s(new Scene2d());
  s->program_ = link(shaders::scene2d_vert, shaders::scene2d_frag, "scene2d.frag", error);
  if (!s->program_) return nullptr;
  s->heat_program_ = link(shaders::scene2d_vert, shaders::heatmap_frag, "heatmap.frag", error);
  if (!s->heat_program_) return nullptr;
  glGenVertexArrays(1, &s->vao_);
  glGenBuffers(1, &s->vbo_);
  glBindVertexArray(s->vao_);
  glBindBuffer(GL_ARRAY_BUFFER, s->vbo_);
  glEnableVertexAttribArray(0);
  glEnableVertexAttribArray(1);
  glEnableVertexAttribArray(2);
  glVertexAttribPointer(0, 2, GL_FLOAT, GL_FALSE, sizeof(Vertex), reinterpret_cast<void*>(0));
  glVertexAttribPointer(1, 2, GL_FLOAT, GL_FALSE, sizeof(Vertex), reinterpret_cast<void*>(2 * sizeof(float)));
  glVertexAttribPointer(2, 4, GL_FLOAT, GL_FALSE, sizeof(Vertex), reinterpret_cast<void*>(4 * sizeof(float)));
  glBindVertexArray(0);
  glBindBuffer(GL_ARRAY_BUFFER, 0);
  glGenTextures(1, &s->heat_tex_);
  s->resize(width, height);
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) == 0 && error) *error = "scene2d: framebuffer incomplete";
  return s;
}

Scene2d::~Scene2d() {
  glDeleteFramebuffers(1, &fbo_);
  glDeleteTextures(1, &color_);
  glDeleteTextures(1, &heat_tex_);
  glDeleteBuffers(1, &vbo_);
  glDeleteVertexArrays(1, &vao_);
  glDeleteProgram(program_);
  glDeleteProgram(heat_program_);
}

void Scene2d::resize(int width, int height) {
  if (width == width_ && height == height_ && fbo_) return;
  width_ = std::max(1, width);
  height_ = std::max(1, height);
  GLint previous = 0;
  glGetIntegerv(GL_FRAMEBUFFER_BINDING, &previous);
  if (!fbo_) glGenFramebuffers(1, &fbo_);
  if (!color_) glGenTextures(1, &color_);
  glBindTexture(GL_TEXTURE_2D, color_);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, width_, height_, 0, GL_RGBA, GL_UNSIGNED_BYTE, nullptr);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, color_, 0);
  glBindFramebuffer(GL_FRAMEBUFFER, static_cast<GLuint>(previous));
}

void Scene2d::begin(const Eigen::Vector2d& center, double half, const Rgba& background) {
  center_ = center;
  half_ = half;
  background_ = background;
  if (width_ >= height_) {
    sy_ = 1.0 / half;
    sx_ = sy_ * height_ / width_;
  } else {
    sx_ = 1.0 / half;
    sy_ = sx_ * width_ / height_;
  }
  vertices_.clear();
  batches_.clear();
  heat_on_ = false;
}

double Scene2d::pixel_size() const { return 2.0 / (sx_ * width_); }

Eigen::Vector2d Scene2d::pixel_to_world(double px, double py) const {
  const double cx = 2.0 * px / width_ - 1.0, cy = 1.0 - 2.0 * py / height_;
  return {cx / sx_ + center_.x(), cy / sy_ + center_.y()};
}

void Scene2d::push_quad(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& c, const Eigen::Vector2d& d,
                        const Rgba& color, int mode, float rim, const std::array<float, 8>& l) {
  if (batches_.empty() || batches_.back().mode != mode || batches_.back().rim != rim)
    batches_.push_back({mode, rim, vertices_.size(), 0});
  auto v = [&](const Eigen::Vector2d& p, float u, float w) {
    vertices_.push_back({static_cast<float>(p.x()), static_cast<float>(p.y()), u, w, color[0], color[1], color[2], color[3]});
  };
  // two triangles a-b-c, a-c-d
  v(a, l[0], l[1]);
  v(b, l[2], l[3]);
  v(c, l[4], l[5]);
  v(a, l[0], l[1]);
  v(c, l[4], l[5]);
  v(d, l[6], l[7]);
  batches_.back().count += 6;
}

void Scene2d::rect(const Eigen::Vector2d& lo, const Eigen::Vector2d& hi, const Rgba& color) {
  push_quad(lo, {hi.x(), lo.y()}, hi, {lo.x(), hi.y()}, color, 0, 0.f, {0, 0, 0, 0, 0, 0, 0, 0});
}

void Scene2d::disc(const Eigen::Vector2d& c, double r, const Rgba& color, float rim) {
  // the quad is one pixel larger than the disc so that the smoothed edge is not clipped
  const double e = r + pixel_size();
  const float k = static_cast<float>(e / r);
  push_quad(c + Eigen::Vector2d(-e, -e), c + Eigen::Vector2d(e, -e), c + Eigen::Vector2d(e, e), c + Eigen::Vector2d(-e, e), color, 1,
            rim, {-k, -k, k, -k, k, k, -k, k});
}

void Scene2d::dot(const Eigen::Vector2d& c, double radius_px, const Rgba& color) { disc(c, radius_px * pixel_size(), color); }

void Scene2d::stroke(const std::vector<Eigen::Vector2d>& points, double width_px, const Rgba& color) {
  const double half = 0.5 * (width_px + 1.0) * pixel_size();
  const float k = static_cast<float>((width_px + 1.0) / std::max(width_px, 1e-3));
  for (size_t i = 1; i < points.size(); ++i) {
    const Eigen::Vector2d d = points[i] - points[i - 1];
    const double len = d.norm();
    if (len < 1e-12) continue;
    const Eigen::Vector2d n = Eigen::Vector2d(-d.y(), d.x()) / len * half;
    const Eigen::Vector2d t = d / len * (0.5 * width_px * pixel_size());  // overlap the joints a little
    const Eigen::Vector2d a = points[i - 1] - t, b = points[i] + t;
    push_quad(a - n, b - n, b + n, a + n, color, 2, 0.f, {0, -k, 1, -k, 1, k, 0, k});
  }
}

void Scene2d::ring(const Eigen::Vector2d& c, double r, double width_px, const Rgba& color) {
  std::vector<Eigen::Vector2d> pts;
  const int n = 96;
  for (int i = 0; i <= n; ++i) {
    const double a = 2 * M_PI * i / n;
    pts.emplace_back(c.x() + r * std::cos(a), c.y() + r * std::sin(a));
  }
  stroke(pts, width_px, color);
}

void Scene2d::heat(const std::vector<float>& values, int nx, int ny, const Eigen::Vector2d& lo, const Eigen::Vector2d& hi,
                   float alpha) {
  if (nx <= 0 || ny <= 0 || values.size() != static_cast<size_t>(nx) * static_cast<size_t>(ny)) return;
  glBindTexture(GL_TEXTURE_2D, heat_tex_);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_R32F, nx, ny, 0, GL_RED, GL_FLOAT, values.data());
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  heat_on_ = true;
  heat_alpha_ = alpha;
  heat_lo_ = lo;
  heat_hi_ = hi;
}

void Scene2d::render() {
  GLint previous_fbo = 0, viewport[4];
  glGetIntegerv(GL_FRAMEBUFFER_BINDING, &previous_fbo);
  glGetIntegerv(GL_VIEWPORT, viewport);
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  glViewport(0, 0, width_, height_);
  glDisable(GL_SCISSOR_TEST);
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_CULL_FACE);
  glClearColor(background_[0], background_[1], background_[2], background_[3]);
  glClear(GL_COLOR_BUFFER_BIT);
  glEnable(GL_BLEND);
  glBlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ONE, GL_ONE_MINUS_SRC_ALPHA);

  // The heat quad goes first, after the floor (the first batch), below everything else.
  std::vector<Vertex> all = vertices_;
  size_t heat_first = all.size();
  if (heat_on_) {
    const float x0 = static_cast<float>(heat_lo_.x()), y0 = static_cast<float>(heat_lo_.y());
    const float x1 = static_cast<float>(heat_hi_.x()), y1 = static_cast<float>(heat_hi_.y());
    const Vertex q[6] = {{x0, y0, 0, 0, 1, 1, 1, 1}, {x1, y0, 1, 0, 1, 1, 1, 1}, {x1, y1, 1, 1, 1, 1, 1, 1},
                         {x0, y0, 0, 0, 1, 1, 1, 1}, {x1, y1, 1, 1, 1, 1, 1, 1}, {x0, y1, 0, 1, 1, 1, 1, 1}};
    all.insert(all.end(), q, q + 6);
  }
  glBindVertexArray(vao_);
  glBindBuffer(GL_ARRAY_BUFFER, vbo_);
  glBufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(all.size() * sizeof(Vertex)), all.data(), GL_STREAM_DRAW);
  const float view[4] = {static_cast<float>(center_.x()), static_cast<float>(center_.y()), static_cast<float>(sx_),
                         static_cast<float>(sy_)};
  auto draw_batch = [&](const Batch& b) {
    glUseProgram(program_);
    glUniform4fv(glGetUniformLocation(program_, "u_view"), 1, view);
    glUniform1i(glGetUniformLocation(program_, "u_mode"), b.mode);
    glUniform1f(glGetUniformLocation(program_, "u_rim"), b.rim);
    glDrawArrays(GL_TRIANGLES, static_cast<GLint>(b.first), static_cast<GLsizei>(b.count));
  };
  size_t next = 0;
  if (!batches_.empty() && batches_[0].mode == 0) draw_batch(batches_[next++]);
  if (heat_on_) {
    glUseProgram(heat_program_);
    glUniform4fv(glGetUniformLocation(heat_program_, "u_view"), 1, view);
    glUniform1f(glGetUniformLocation(heat_program_, "u_alpha"), heat_alpha_);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, heat_tex_);
    glUniform1i(glGetUniformLocation(heat_program_, "u_field"), 0);
    glDrawArrays(GL_TRIANGLES, static_cast<GLint>(heat_first), 6);
  }
  for (; next < batches_.size(); ++next) draw_batch(batches_[next]);

  glBindVertexArray(0);
  glBindBuffer(GL_ARRAY_BUFFER, 0);
  glUseProgram(0);
  glBindFramebuffer(GL_FRAMEBUFFER, static_cast<GLuint>(previous_fbo));
  glViewport(viewport[0], viewport[1], viewport[2], viewport[3]);
}

}  // namespace dd::ui
