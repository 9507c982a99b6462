#include "ui/console.h"

#include <GL/gl.h>  // the scene textures
#include <imgui.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <filesystem>

#include "envs/registry.h"
#include "ui/console_state.h"

namespace dd::ui {
namespace fs = std::filesystem;

namespace console {

ImFont* g_bold = nullptr;
ImFont* g_big = nullptr;

namespace {

void setup_style() {
  ImGuiIO& io = ImGui::GetIO();
  const char* regular = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf";
  const char* bold = "/usr/share/fonts/truetype/dejavu/DejaVuSans-Bold.ttf";
  if (io.Fonts->Fonts.empty()) {
    if (fs::exists(regular) && fs::exists(bold)) {
      io.Fonts->AddFontFromFileTTF(regular, 15.f);
      g_bold = io.Fonts->AddFontFromFileTTF(bold, 15.f);
      g_big = io.Fonts->AddFontFromFileTTF(bold, 24.f);
    } else {
      spdlog::warn("fonts-dejavu-core not found ({}); using ImGui's built-in font", regular);
      io.Fonts->AddFontDefault();
    }
  }
  ImGuiStyle& st = ImGui::GetStyle();
  ImGui::StyleColorsDark(&st);
  st.WindowRounding = 6.f;
  st.FrameRounding = 4.f;
  st.GrabRounding = 4.f;
  st.WindowBorderSize = 0.f;
  st.WindowPadding = ImVec2(12, 10);
  st.ItemSpacing = ImVec2(8, 6);
  ImVec4* c = st.Colors;
  c[ImGuiCol_WindowBg] = ImVec4(0.105f, 0.113f, 0.133f, 1.f);
  c[ImGuiCol_ChildBg] = ImVec4(0.085f, 0.092f, 0.110f, 1.f);
  c[ImGuiCol_TitleBg] = c[ImGuiCol_TitleBgActive] = ImVec4(0.140f, 0.150f, 0.178f, 1.f);
  c[ImGuiCol_PopupBg] = ImVec4(0.120f, 0.128f, 0.150f, 0.98f);
  c[ImGuiCol_PlotHistogram] = ImVec4(0.28f, 0.52f, 0.92f, 1.f);
  c[ImGuiCol_Button] = ImVec4(0.20f, 0.30f, 0.48f, 1.f);
  c[ImGuiCol_ButtonHovered] = ImVec4(0.26f, 0.40f, 0.64f, 1.f);
  c[ImGuiCol_Separator] = ImVec4(1.f, 1.f, 1.f, 0.08f);
  c[ImGuiCol_Text] = ImVec4(0.90f, 0.91f, 0.94f, 1.f);
  c[ImGuiCol_TextDisabled] = ImVec4(0.55f, 0.57f, 0.63f, 1.f);
}

std::string default_out(const std::string& task, const std::string& method) {
  for (int i = 1;; ++i) {
    const std::string d = "out/gui/" + task + "_" + method + "_" + std::to_string(i);
    if (!fs::exists(d)) return d;
  }
}


}  // namespace
}  // namespace console

using namespace console;

Console::Console(const ConsoleOptions& options) : s_(std::make_unique<State>()) {
  State& s = *s_;
  s.o = options;
  const ExperimentConfig& c = s.o.config;
  c.validate();
  if (s.o.out.empty()) s.o.out = default_out(c.task, s.o.method);
  fs::create_directories(s.o.out + "/checkpoints");
  const std::string dataset = s.o.out + "/dataset.hdf5";
  if (fs::exists(dataset))
    throw Error(dataset + ": already exists; a console session never mixes its data into an earlier one's (choose another --out)");
  s.env = make_env(c.task);
  s.teleop = s.env->teleoperation();
  if (!s.teleop) throw Error("console: task " + c.task + " cannot be driven by an operator (its Env has no teleoperation)");
  s.scripted = make_expert(c.task, s.o.expert_mode.empty() ? c.expert : s.o.expert_mode);
  s.expert = std::make_unique<ConsoleExpert>(
      *s.scripted, [&s] { return s.operator_drives() && !s.o.scripted_operator; },
      [&s](const Env& env) { return s.teleop->action(env, operator_input(s)); });
  MethodConfig method_config = c.method;
  method_config.compare_scores.clear();  // an RQ1 instrument (eval); the console gates on the main rule
  s.method = make_method(s.o.method, c.policy, method_config, c.dagger.seed);
  s.writer = std::make_unique<DatasetWriter>(dataset, env_args(c.task));
  TrainConfig train = c.train;
  s.session = std::make_unique<DaggerSession>(*s.env, *s.expert, *s.method, c.dagger, train, s.writer.get());
  s.session->adopt_at_first_update(s.o.policies);
  s.log = std::make_unique<EventLog>(s.o.out + "/session.jsonl");
  s.log->note("console_start", "task " + c.task + ", method " + s.o.method + ", out " + s.o.out);
  if (!s.o.policies.empty()) s.log->note("console_policy", "first update adopts " + s.o.policies.front());
  s.session->add_observer([&s](const SessionEvent& e) {
    std::lock_guard<std::mutex> lock(s.mu);
    s.queue.push_back(e);
  });
  setup_style();
  std::string error;
  s.scene = Scene2d::create(640, 640, &error);
  if (!s.scene) throw Error("console: " + error);
  s.physics = s.env->physics();
  if (s.physics) {
    s.mjview = std::make_unique<MujocoView>(s.physics->model);
    s.cameras = s.mjview->camera_names();
    glGenTextures(1, &s.mj_tex);
  }
  spdlog::info("console: {} on {}, data set {}, log {}", s.o.method, c.task, dataset, s.log->path());
}

Console::~Console() {
  try {
    shutdown();
  } catch (const std::exception& e) {
    spdlog::error("console: {}", e.what());
  }
}

int Console::episode() const { return s_->session->episode(); }
int Console::updates() const { return s_->session->updates(); }
int Console::queries() const { return s_->view.counts().queries; }
int Console::operator_takeovers() const { return s_->view.counts().takeovers; }
bool Console::session_done() const { return s_->session->done(); }
const std::string& Console::log_path() const { return s_->log->path(); }
bool Console::quit() const { return s_->quitting; }
bool Console::busy() const { return s_->busy(); }

std::vector<std::string> Console::take_screenshot_requests() {
  std::vector<std::string> out;
  out.swap(s_->shots);
  return out;
}

std::vector<std::pair<std::string, std::string>> console_keys() {
  std::vector<std::pair<std::string, std::string>> rows;
  for (const Binding& b : bindings()) rows.emplace_back(b.keys_label, b.description);
  return rows;
}

void Console::shutdown() {
  State& s = *s_;
  if (s.shut) return;
  s.shut = true;
  if (s.worker.busy()) {
    spdlog::info("console: waiting for the {} to finish", to_string(s.worker.job()));
    s.worker.collect(/*wait=*/true);
  }
  if (s.session->in_episode() && s.session->expert_acted()) {
    s.session->end_episode_now();  // its expert steps reach the data set
    s.log->note("saved_partial_episode", "episode " + std::to_string(s.session->episode()));
  }
  {
    std::lock_guard<std::mutex> lock(s.mu);
    for (const auto& e : s.queue) (*s.log)(e);
    s.queue.clear();
  }
  if (s.session->updates() > 0) {
    const std::string dir = s.o.out + "/checkpoints/final";
    fs::create_directories(dir);
    s.method->save(dir);
  }
  s.log->note("console_end", std::to_string(s.session->expert_demos()) + " expert demos, " +
                                 std::to_string(s.session->updates()) + " updates");
  if (s.frames > 1 && !s.o.fixed_step)
    spdlog::info("console: frame time over the session: mean {:.1f} ms, max {:.1f} ms over {} frames", s.frame_sum / (s.frames - 1),
                 s.frame_max, s.frames - 1);
  if (s.run_frames > 0 && !s.o.fixed_step)
    spdlog::info("console: frame time while the robot was in control: mean {:.1f} ms, max {:.1f} ms over {} frames",
                 s.run_frame_sum / s.run_frames, s.run_frame_max, s.run_frames);
  if (s.busy_frames > 0 && !s.o.fixed_step)
    spdlog::info("console: frame time while the worker trained: mean {:.1f} ms, max {:.1f} ms over {} frames",
                 s.busy_frame_sum / s.busy_frames, s.busy_frame_max, s.busy_frames);
  spdlog::info("console: data set {} ({} episodes), log {}", s.writer->path(), s.writer->episodes(), s.log->path());
}

void Console::frame(const FrameInput& in) {
  State& s = *s_;
  s.worker.collect();  // a finished job's result, applied here on the frame thread
  s.frame_ms = 0.9 * s.frame_ms + 0.1 * in.dt * 1e3;
  if (s.frames++ > 0) {
    s.frame_sum += in.dt * 1e3;
    s.frame_max = std::max(s.frame_max, in.dt * 1e3);
    if (!s.updating() && s.session->in_episode() && s.session->control() == Control::kRobot) {  // the robot deciding and acting
      s.run_frame_sum += in.dt * 1e3;
      s.run_frame_max = std::max(s.run_frame_max, in.dt * 1e3);
      ++s.run_frames;
    }
  }
  if (s.worker.job() == WorkerJob::kUpdate) {
    s.busy_frame_sum += in.dt * 1e3;
    s.busy_frame_max = std::max(s.busy_frame_max, in.dt * 1e3);
    ++s.busy_frames;
  }
  drain(s);
  std::vector<Command> commands;
  commands.swap(s.from_views);
  commands.insert(commands.end(), in.commands.begin(), in.commands.end());
  for (Command c : commands) execute(s, c);
  if (in.close_requested) {
    if (s.session->in_episode() && s.session->expert_acted() && !s.o.fixed_step) s.close_dialog = true;
    else s.quitting = true;
  }
  s.jog = in.jog;
  s.lift = in.lift;
  if ((s.jog.squaredNorm() > 0 || s.lift != 0) && !s.busy() && !s.operator_drives() && !s.awaiting && s.session->in_episode() &&
      s.session->control() == Control::kRobot && !s.o.scripted_operator)
    take_over(s);  // driving is taking over
  advance(s, in.dt);
  if (s.update_shot_due && !s.busy()) {
    s.update_shot_due = false;
    s.request_shot("update");
  }
  if (s.o.fixed_step && s.session->done() && !s.busy()) s.quitting = true;

  const ImVec2 size = ImGui::GetIO().DisplaySize;
  top_bar(s, size);
  const float top = 44, margin = 6;
  const float scene_w = std::min(size.y - top - margin, size.x * 0.52f);
  scene_view(s, ImVec2(margin, top), ImVec2(scene_w, size.y - top - margin));
  const float x = margin * 2 + scene_w, w = size.x - x - margin, h = size.y - top - margin;
  loss_plot(s, ImVec2(x, top), ImVec2(w, h * 0.42f));
  timeline_view(s, ImVec2(x, top + h * 0.42f + margin), ImVec2(w, h * 0.30f - margin));
  session_view(s, ImVec2(x, top + h * 0.72f + margin), ImVec2(w, h * 0.28f - margin));
  help_overlay(s, size, s.from_views);
  close_dialog(s, s.from_views);
}

}  // namespace dd::ui
