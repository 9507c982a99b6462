#include "ui/console_app.h"

#include <GL/gl.h>
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>
#include <spdlog/spdlog.h>
#include <yaml-cpp/yaml.h>

#include <cfloat>
#include <chrono>
#include <filesystem>
#include <map>
#include <set>
#include <thread>

#include "core/config.h"
#include "ui/headless_gl.h"
#include "ui/image_io.h"
#include "ui/script.h"

namespace dd::ui {
namespace {

namespace fs = std::filesystem;

// The framebuffer currently bound, as a top-down image (alpha forced opaque).
Image grab(int width, int height) {
  Image img{width, height, read_framebuffer_rgba(width, height)};
  for (size_t i = 3; i < img.rgba.size(); i += 4) img.rgba[i] = 255;
  return img;
}

void save_shots(Console& console, const std::string& dir, int width, int height, std::set<std::string>* written) {
  for (const std::string& name : console.take_screenshot_requests()) {
    if (dir.empty()) continue;
    const std::string path = dir + "/" + name + ".png";
    write_png(path, grab(width, height));
    spdlog::info("screenshot {}", path);
    if (written) written->insert(name);
  }
}

void render_imgui(int width, int height) {
  ImGui::Render();
  glViewport(0, 0, width, height);
  glClearColor(0.06f, 0.065f, 0.08f, 1.f);
  glClear(GL_COLOR_BUFFER_BIT);
  ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
}

// What drives the console: where frames are drawn and input comes from. One loop (run_console)
// serves both the window and the headless runner.
class Platform {
 public:
  virtual ~Platform() = default;
  /// After the console exists (it loads the fonts before a backend builds its atlas): the ImGui
  /// platform backend, if any.
  virtual void start() {}
  /// This frame's input.
  virtual FrameInput input(const Console& console) = 0;
  /// Before ImGui's NewFrame: make the context current, feed the platform backend.
  virtual void new_frame() = 0;
  /// The framebuffer's size in pixels.
  virtual std::pair<int, int> size() const = 0;
  /// After the frame is rendered and its screenshots written: present it; true to stop.
  virtual bool present(const Console& console, const std::set<std::string>& written) = 0;
  /// The exit code, once the loop has stopped.
  virtual int exit_code(const std::set<std::string>& written) const { (void)written; return 0; }
  /// Before the ImGui context goes: the platform backend's shutdown.
  virtual void stop() {}
};

int run_console(const ConsoleOptions& options, const ConsoleRunOptions& run, Platform& platform) {
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;
  if (!run.screenshots.empty()) fs::create_directories(run.screenshots);
  int code = 0;
  {
    Console console(options);
    platform.start();
    ImGui_ImplOpenGL3_Init("#version 130");
    std::set<std::string> written;
    while (!console.quit()) {
      const FrameInput in = platform.input(console);
      platform.new_frame();
      ImGui_ImplOpenGL3_NewFrame();
      ImGui::NewFrame();
      console.frame(in);
      const auto [w, h] = platform.size();
      render_imgui(w, h);
      save_shots(console, run.screenshots, w, h, &written);
      if (platform.present(console, written)) break;
    }
    code = platform.exit_code(written);
    console.shutdown();
    ImGui_ImplOpenGL3_Shutdown();
    platform.stop();
  }
  ImGui::DestroyContext();
  return code;
}

// EGL with no display, a fixed time step, input from a script (or none: the scripted expert plays
// the operator); stops when the three named screenshots are written, or after max_frames.
class HeadlessPlatform : public Platform {
 public:
  HeadlessPlatform(const ConsoleRunOptions& run, std::vector<ScriptEvent> script)
      : run_(run), script_(std::move(script)), max_frames_(run.max_frames > 0 ? run.max_frames : 20000) {
    std::string error;
    gl_ = HeadlessGL::create(run.width, run.height, &error);
    if (!gl_) throw Error(error);
  }
  FrameInput input(const Console& console) override {
    FrameInput in;
    in.dt = kDt;
    for (ScriptEvent& e : script_) {
      if (e.start < 0) {
        const bool fired = (e.on == "query" && console.queries() > 0) || (e.on == "update" && console.updates() > 0) ||
                           (e.on == "takeover" && console.operator_takeovers() > 0) || (e.on == "episode" && console.episode() > 1);
        if (fired) e.start = frame_ + e.after;
      }
      if (e.start < 0 || frame_ < e.start) continue;
      if (e.command && frame_ == e.start) in.commands.push_back(*e.command);
      if (!e.hold.isZero() && frame_ < e.start + e.frames) in.jog += e.hold;
    }
    return in;
  }
  void new_frame() override {
    ImGuiIO& io = ImGui::GetIO();
    io.DisplaySize = ImVec2(static_cast<float>(run_.width), static_cast<float>(run_.height));
    io.DeltaTime = static_cast<float>(kDt);
    io.MousePos = ImVec2(-FLT_MAX, -FLT_MAX);
    gl_->make_current();  // (MuJoCo's renderer binds framebuffers of its own)
  }
  std::pair<int, int> size() const override { return {run_.width, run_.height}; }
  bool present(const Console& console, const std::set<std::string>& written) override {
    if (!run_.screenshots.empty() && std::includes(written.begin(), written.end(), kWanted.begin(), kWanted.end())) return true;
    // while the worker trains, frames wait for it instead of counting down the budget
    if (console.busy()) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      return false;
    }
    return ++frame_ >= max_frames_;
  }
  int exit_code(const std::set<std::string>& written) const override {
    if (run_.screenshots.empty()) return 0;
    if (frame_ >= max_frames_) spdlog::warn("headless console: stopped after {} frames", max_frames_);
    int code = 0;
    for (const std::string& w : kWanted)
      if (!written.count(w)) {
        spdlog::error("headless console: no {}.png (the event did not happen within {} frames)", w, frame_);
        code = 3;
      }
    return code;
  }

 private:
  static constexpr double kDt = 1.0 / 20;
  inline static const std::set<std::string> kWanted = {"query", "takeover", "update"};
  const ConsoleRunOptions& run_;
  std::vector<ScriptEvent> script_;
  std::unique_ptr<HeadlessGL> gl_;
  int frame_ = 0;
  const int max_frames_;
};

std::vector<Command>* g_commands = nullptr;

void key_callback(GLFWwindow*, int key, int, int action, int) {
  // ImGui 1.86 has no input queue: keep every press, however short, for the next frame
  if (!g_commands || (action != GLFW_PRESS && action != GLFW_REPEAT)) return;
  if (auto c = command_for_key(key, action == GLFW_REPEAT)) g_commands->push_back(*c);
}

void glfw_error(int code, const char* what) { spdlog::error("GLFW error {}: {}", code, what); }

// A GLFW window: keys through the binding table, arrow keys and PageUp/PageDown held, a gamepad.
class WindowPlatform : public Platform {
 public:
  WindowPlatform(const ConsoleRunOptions& run, const std::string& title) {
    glfwSetErrorCallback(glfw_error);
    if (!glfwInit()) throw Error("gui: GLFW could not start (no display? use --headless)");
    window_ = glfwCreateWindow(run.width, run.height, title.c_str(), nullptr, nullptr);
    if (!window_) {
      glfwTerminate();
      throw Error("gui: could not open a window with an OpenGL context");
    }
    glfwMakeContextCurrent(window_);
    glfwSwapInterval(1);
    g_commands = &commands_;
    glfwSetKeyCallback(window_, key_callback);  // installed first, so ImGui's backend chains to it
  }
  ~WindowPlatform() override {
    g_commands = nullptr;
    glfwDestroyWindow(window_);
    glfwTerminate();
  }
  void start() override {
    ImGui_ImplGlfw_InitForOpenGL(window_, true);
    spdlog::info("console window open; F1 lists the keys");
    last_ = std::chrono::steady_clock::now();
  }
  FrameInput input(const Console&) override {
    glfwPollEvents();
    FrameInput in;
    const auto now = std::chrono::steady_clock::now();
    in.dt = std::chrono::duration<double>(now - last_).count();
    last_ = now;
    in.commands.swap(commands_);
    auto down = [&](int key) { return glfwGetKey(window_, key) == GLFW_PRESS ? 1 : 0; };
    in.jog = Eigen::Vector2d(down(GLFW_KEY_RIGHT) - down(GLFW_KEY_LEFT), down(GLFW_KEY_UP) - down(GLFW_KEY_DOWN));
    in.lift = down(GLFW_KEY_PAGE_UP) - down(GLFW_KEY_PAGE_DOWN);
    GLFWgamepadstate pad;
    if (glfwJoystickIsGamepad(GLFW_JOYSTICK_1) && glfwGetGamepadState(GLFW_JOYSTICK_1, &pad)) {
      const float x = pad.axes[GLFW_GAMEPAD_AXIS_LEFT_X], y = -pad.axes[GLFW_GAMEPAD_AXIS_LEFT_Y];
      if (std::abs(x) > 0.15f || std::abs(y) > 0.15f) in.jog = Eigen::Vector2d(x, y);
      for (auto [button, command] : gamepad_bindings()) {
        if (pad.buttons[button] && !previous_buttons_[button]) in.commands.push_back(command);
        previous_buttons_[button] = pad.buttons[button];
      }
    }
    if (glfwWindowShouldClose(window_)) {
      in.close_requested = true;
      glfwSetWindowShouldClose(window_, GLFW_FALSE);  // the console decides (it may ask first)
    }
    return in;
  }
  void new_frame() override { ImGui_ImplGlfw_NewFrame(); }
  std::pair<int, int> size() const override {
    int w = 0, h = 0;
    glfwGetFramebufferSize(window_, &w, &h);
    return {w, h};
  }
  bool present(const Console&, const std::set<std::string>&) override {
    glfwSwapBuffers(window_);
    return false;
  }
  void stop() override { ImGui_ImplGlfw_Shutdown(); }

 private:
  GLFWwindow* window_ = nullptr;
  std::vector<Command> commands_;
  std::chrono::steady_clock::time_point last_;
  unsigned char previous_buttons_[GLFW_GAMEPAD_BUTTON_LAST + 1] = {};
};

}  // namespace

int run_headless(ConsoleOptions options, const ConsoleRunOptions& run) {
  std::vector<ScriptEvent> script;
  if (!run.script.empty()) script = load_script(run.script);
  options.fixed_step = true;
  options.scripted_operator = run.script.empty();
  HeadlessPlatform platform(run, std::move(script));
  return run_console(options, run, platform);
}

int run_window(ConsoleOptions options, const ConsoleRunOptions& run) {
  WindowPlatform platform(run, "diffdagger: " + options.config.task + ", " + options.method);
  return run_console(options, run, platform);
}

}  // namespace dd::ui
