// The console's state and the functions that share it. Internal to ui/ (ui/README.md says who owns
// what): console.cpp sets up, runs the frame and shuts down; console_control.cpp turns input and the
// worker's results into session calls (on the frame thread, the only code that changes the session);
// console_scene.cpp draws the scene; console_panels.cpp draws the plot, the timeline, the session
// panel, the top bar and the dialogs. ui/worker.h runs the one background job.
#pragma once

#include <imgui.h>

#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <vector>

#include "core/config.h"
#include "core/dataset.h"
#include "core/event_log.h"
#include "core/method.h"
#include "core/session.h"
#include "ui/console.h"
#include "ui/mujoco_view.h"
#include "ui/scene2d.h"
#include "ui/view_model.h"
#include "ui/worker.h"

namespace dd::ui {
namespace console {

// Control-mode colours (the paper's figure 5 keeps robot, query, expert and time-out apart).
inline ImU32 control_color(Control c, int alpha = 255) {
  switch (c) {
    case Control::kRobot: return IM_COL32(72, 132, 235, alpha);
    case Control::kExpertQuery: return IM_COL32(62, 184, 112, alpha);
    case Control::kExpertDemo: return IM_COL32(150, 154, 166, alpha);
    case Control::kExpertTimeout: return IM_COL32(226, 86, 74, alpha);
    case Control::kOperator: return IM_COL32(178, 108, 232, alpha);
  }
  return IM_COL32(255, 255, 255, alpha);
}

inline Rgba to_rgba(ImU32 c, float alpha = 1.f) {
  const ImVec4 v = ImGui::ColorConvertU32ToFloat4(c);
  return {v.x, v.y, v.z, v.w * alpha};
}

inline const char* control_label(Control c) {
  switch (c) {
    case Control::kRobot: return "robot";
    case Control::kExpertQuery: return "expert (query)";
    case Control::kExpertDemo: return "expert demo";
    case Control::kExpertTimeout: return "expert (time-out)";
    case Control::kOperator: return "operator";
  }
  return "?";
}

inline constexpr ImU32 kQueryAmber = IM_COL32(255, 176, 32, 255);
inline constexpr ImU32 kViolationRed = IM_COL32(240, 70, 70, 255);
inline constexpr ImU32 kThresholdColor = IM_COL32(255, 176, 32, 255);
inline constexpr ImU32 kScoreColor = IM_COL32(110, 170, 255, 255);
inline constexpr ImU32 kGrid = IM_COL32(255, 255, 255, 22);
inline constexpr ImU32 kAxisText = IM_COL32(200, 204, 214, 170);

extern ImFont* g_bold;  // the console's fonts (setup_style); null before it runs
extern ImFont* g_big;

// An expert seen by the session: the scripted one, or the operator at the console.
class ConsoleExpert : public Expert {
 public:
  ConsoleExpert(Expert& scripted, std::function<bool()> operator_drives, std::function<Vec(const Env&)> operator_action)
      : scripted_(scripted), drives_(std::move(operator_drives)), action_(std::move(operator_action)) {}
  std::string name() const override { return "console(" + scripted_.name() + ")"; }
  void reset(uint64_t seed) override { scripted_.reset(seed); }
  Vec act(const Env& env) override { return drives_() ? action_(env) : scripted_.act(env); }

 private:
  Expert& scripted_;
  std::function<bool()> drives_;
  std::function<Vec(const Env&)> action_;
};


inline std::string fmt_seconds(double s) {
  char b[32];
  std::snprintf(b, sizeof b, s < 10 ? "%.1f s" : "%.0f s", s);
  return b;
}


}  // namespace console

struct Console::State {
  ConsoleOptions o;
  std::unique_ptr<Env> env;  // seen through its scene description (Env::plane, Env::physics), never by its type
  std::unique_ptr<Expert> scripted;
  std::unique_ptr<console::ConsoleExpert> expert;
  std::unique_ptr<Method> method;
  std::unique_ptr<DatasetWriter> writer;
  std::unique_ptr<DaggerSession> session;
  std::unique_ptr<EventLog> log;
  std::unique_ptr<Scene2d> scene;
  // physics tasks: MuJoCo's view, shown through a texture
  std::optional<PhysicsScene> physics;
  std::vector<std::string> cameras;  // the model's cameras (C cycles the free camera and these)
  std::unique_ptr<MujocoView> mjview;
  unsigned mj_tex = 0;
  std::vector<double> mj_key;  // what the texture shows (re-rendered when it changes)
  FreeCamera free_cam;
  int camera = -1;  // -1: the free camera, else the model's camera index
  std::unique_ptr<Teleoperation> teleop;  // the task's: operator input to action
  double lift = 0;

  // events from the session (either thread), handled on the frame thread
  std::mutex mu;
  std::vector<SessionEvent> queue;

  // the worker: policy updates, the loss field and (windowed runs) the robot's decisions; their
  // results are applied here on the frame thread (ui/worker.h)
  Worker worker;
  MethodDecision decision;  // a decision the worker computed, handed to the session when ready
  double decision_s = 0;
  bool decision_ready = false;
  std::vector<Command> from_views;  // commands the views gave (dragging a target takes over), run at the next frame's start
  std::vector<Command> deferred;  // commands that change the session, given while a decision was being computed
  bool busy() const { return worker.busy(); }
  bool updating() const { return worker.busy() && worker.job() != WorkerJob::kDecision; }
  bool deciding() const { return worker.job() == WorkerJob::kDecision; }

  // what the panels show, built from the session's events and steps (the controller feeds it)
  ViewModel view;
  int saves = 0;

  // operator state
  enum class Answer { kNobody, kOperator, kScripted };
  Answer answering = Answer::kNobody;
  bool awaiting = false;  // a query waits for the operator
  bool paused = false, step_once = false;
  Eigen::Vector2d jog{0, 0};
  bool dragging = false;
  Eigen::Vector2d drag_target{0, 0};
  int operator_countdown = -1;
  bool show_help = false, show_field = false, field_valid = false, field_wanted = false;
  std::vector<float> field;
  int field_n = 28;
  bool close_dialog = false, quitting = false, shut = false;
  double tick_budget = 0;

  // screenshots
  std::vector<std::string> shots;
  std::set<std::string> shots_taken;
  int takeover_steps = -1;
  bool update_shot_due = false;
  int screenshot_count = 0;

  // frame times
  double frame_ms = 0, busy_frame_sum = 0, busy_frame_max = 0, frame_sum = 0, frame_max = 0, run_frame_sum = 0, run_frame_max = 0;
  int busy_frames = 0, frames = 0, run_frames = 0;

  std::string status;

  bool operator_drives() const { return answering == Answer::kOperator; }
  void request_shot(const std::string& name) {
    if (shots_taken.insert(name).second) shots.push_back(name);
  }
};


namespace console {

// console_control.cpp: the frame thread's handling of session events, keys and the worker's jobs
void handle_event(Console::State& s, const SessionEvent& e);
void drain(Console::State& s);  // the session's queued events, handled in order
void start_update(Console::State& s);
void start_field(Console::State& s);
void save_policy(Console::State& s);
void answer_as_operator(Console::State& s);
void take_over(Console::State& s);
void execute(Console::State& s, Command c);  // one operator command
void advance(Console::State& s, double dt);  // steps the session as far as this frame allows
OperatorInput operator_input(const Console::State& s);  // what the operator's devices give this step

// console_scene.cpp
void scene_view(Console::State& s, ImVec2 pos, ImVec2 size);
/// A fixed panel of the console's layout (closed with ImGui::End()).
void begin_panel(const char* title, ImVec2 pos, ImVec2 size, ImGuiWindowFlags extra = 0);

// console_panels.cpp: read the state and draw; the key list's and the dialog's buttons give commands
void loss_plot(const Console::State& s, ImVec2 pos, ImVec2 size);
void timeline_view(const Console::State& s, ImVec2 pos, ImVec2 size);
void session_view(const Console::State& s, ImVec2 pos, ImVec2 size);
void top_bar(const Console::State& s, ImVec2 size);
void help_overlay(const Console::State& s, ImVec2 size, std::vector<Command>& given);
void close_dialog(const Console::State& s, std::vector<Command>& given);

}  // namespace console
}  // namespace dd::ui
