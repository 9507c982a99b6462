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

}  // namespace

int run_headless(ConsoleOptions options, const ConsoleRunOptions& run) {
  std::vector<ScriptEvent> script;
  if (!run.script.empty()) script = load_script(run.script);
  options.fixed_step = true;
  options.scripted_operator = run.script.empty();
  if (!run.screenshots.empty()) fs::create_directories(run.screenshots);

  std::string error;
  auto gl = HeadlessGL::create(run.width, run.height, &error);
  if (!gl) throw Error(error);
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGuiIO& io = ImGui::GetIO();
  io.IniFilename = nullptr;
  io.DisplaySize = ImVec2(static_cast<float>(run.width), static_cast<float>(run.height));
  int code = 0;
  {
    Console console(options);  // loads the fonts before the backend builds its atlas
    ImGui_ImplOpenGL3_Init("#version 130");
    const double dt = 1.0 / 20;
    const int max_frames = run.max_frames > 0 ? run.max_frames : 20000;
    std::set<std::string> written;
    const std::set<std::string> wanted = {"query", "takeover", "update"};
    int frame = 0;
    while (frame < max_frames) {
      FrameInput in;
      in.dt = dt;
      for (ScriptEvent& e : script) {
        if (e.start < 0) {
          const bool fired = (e.on == "query" && console.queries() > 0) || (e.on == "update" && console.updates() > 0) ||
                             (e.on == "takeover" && console.operator_takeovers() > 0) || (e.on == "episode" && console.episode() > 1);
          if (fired) e.start = frame + e.after;
        }
        if (e.start < 0 || frame < e.start) continue;
        if (e.command && frame == e.start) in.commands.push_back(*e.command);
        if (!e.hold.isZero() && frame < e.start + e.frames) in.jog += e.hold;
      }
      io.DeltaTime = static_cast<float>(dt);
      io.MousePos = ImVec2(-FLT_MAX, -FLT_MAX);
      gl->make_current();  // (MuJoCo's renderer binds framebuffers of its own)
      ImGui_ImplOpenGL3_NewFrame();
      ImGui::NewFrame();
      console.frame(in);
      render_imgui(run.width, run.height);
      save_shots(console, run.screenshots, run.width, run.height, &written);
      if (console.quit()) break;
      if (!run.screenshots.empty() && std::includes(written.begin(), written.end(), wanted.begin(), wanted.end())) break;
      // while the worker trains, frames wait for it instead of counting down the budget
      if (console.busy()) {
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
        continue;
      }
      ++frame;
    }
    if (frame >= max_frames && !run.screenshots.empty()) spdlog::warn("headless console: stopped after {} frames", max_frames);
    for (const std::string& w : wanted)
      if (!run.screenshots.empty() && !written.count(w)) {
        spdlog::error("headless console: no {}.png (the event did not happen within {} frames)", w, frame);
        code = 3;
      }
    console.shutdown();
    ImGui_ImplOpenGL3_Shutdown();
  }
  ImGui::DestroyContext();
  return code;
}

// ---- the window ----

namespace {

std::vector<Command>* g_commands = nullptr;

void key_callback(GLFWwindow*, int key, int, int action, int) {
  // ImGui 1.86 has no input queue: keep every press, however short, for the next frame
  if (!g_commands || (action != GLFW_PRESS && action != GLFW_REPEAT)) return;
  if (auto c = command_for_key(key, action == GLFW_REPEAT)) g_commands->push_back(*c);
}

void glfw_error(int code, const char* what) { spdlog::error("GLFW error {}: {}", code, what); }

}  // namespace

int run_window(ConsoleOptions options, const ConsoleRunOptions& run) {
  glfwSetErrorCallback(glfw_error);
  if (!glfwInit()) throw Error("gui: GLFW could not start (no display? use --headless)");
  GLFWwindow* window =
      glfwCreateWindow(run.width, run.height, ("diffdagger: " + options.config.task + ", " + options.method).c_str(), nullptr, nullptr);
  if (!window) {
    glfwTerminate();
    throw Error("gui: could not open a window with an OpenGL context");
  }
  glfwMakeContextCurrent(window);
  glfwSwapInterval(1);
  std::vector<Command> commands;
  g_commands = &commands;
  glfwSetKeyCallback(window, key_callback);  // installed first, so ImGui's backend chains to it

  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;
  if (!run.screenshots.empty()) fs::create_directories(run.screenshots);
  int code = 0;
  {
    Console console(options);
    ImGui_ImplGlfw_InitForOpenGL(window, true);
    ImGui_ImplOpenGL3_Init("#version 130");
    spdlog::info("console window open; F1 lists the keys");
    auto last = std::chrono::steady_clock::now();
    unsigned char previous_buttons[GLFW_GAMEPAD_BUTTON_LAST + 1] = {};
    while (!console.quit()) {
      glfwPollEvents();
      FrameInput in;
      const auto now = std::chrono::steady_clock::now();
      in.dt = std::chrono::duration<double>(now - last).count();
      last = now;
      in.commands.swap(commands);
      auto down = [&](int key) { return glfwGetKey(window, key) == GLFW_PRESS ? 1 : 0; };
      in.jog = Eigen::Vector2d(down(GLFW_KEY_RIGHT) - down(GLFW_KEY_LEFT), down(GLFW_KEY_UP) - down(GLFW_KEY_DOWN));
      in.lift = down(GLFW_KEY_PAGE_UP) - down(GLFW_KEY_PAGE_DOWN);
      GLFWgamepadstate pad;
      if (glfwJoystickIsGamepad(GLFW_JOYSTICK_1) && glfwGetGamepadState(GLFW_JOYSTICK_1, &pad)) {
        const float x = pad.axes[GLFW_GAMEPAD_AXIS_LEFT_X], y = -pad.axes[GLFW_GAMEPAD_AXIS_LEFT_Y];
        if (std::abs(x) > 0.15f || std::abs(y) > 0.15f) in.jog = Eigen::Vector2d(x, y);
        for (auto [button, command] : gamepad_bindings()) {
          if (pad.buttons[button] && !previous_buttons[button]) in.commands.push_back(command);
          previous_buttons[button] = pad.buttons[button];
        }
      }
      if (glfwWindowShouldClose(window)) {
        in.close_requested = true;
        glfwSetWindowShouldClose(window, GLFW_FALSE);  // the console decides (it may ask first)
      }
      ImGui_ImplOpenGL3_NewFrame();
      ImGui_ImplGlfw_NewFrame();
      ImGui::NewFrame();
      console.frame(in);
      int w = 0, h = 0;
      glfwGetFramebufferSize(window, &w, &h);
      render_imgui(w, h);
      save_shots(console, run.screenshots, w, h, nullptr);
      glfwSwapBuffers(window);
    }
    console.shutdown();
    ImGui_ImplOpenGL3_Shutdown();
    ImGui_ImplGlfw_Shutdown();
  }
  g_commands = nullptr;
  ImGui::DestroyContext();
  glfwDestroyWindow(window);
  glfwTerminate();
  return code;
}

}  // namespace dd::ui
