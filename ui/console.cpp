#include "ui/console.h"

#include <GL/gl.h>
#include <GLFW/glfw3.h>  // key codes only (ImGui 1.86 indexes keys by GLFW code); no window calls here
#include <imgui.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <deque>
#include <filesystem>
#include <mutex>
#include <set>
#include <thread>

#include "core/config.h"
#include "core/dataset.h"
#include "core/event_log.h"
#include "core/method.h"
#include "core/session.h"
#include "envs/mujoco/arm_env.h"
#include "envs/mujoco/pick_place_expert.h"
#include "envs/nav2d.h"
#include "envs/registry.h"
#include "ui/mujoco_view.h"
#include "ui/scene2d.h"
#include "ui/worker.h"

namespace dd::ui {
namespace fs = std::filesystem;

namespace {

// Control-mode colours (the paper's figure 5 keeps robot, query, expert and time-out apart).
ImU32 control_color(Control c, int alpha = 255) {
  switch (c) {
    case Control::kRobot: return IM_COL32(72, 132, 235, alpha);
    case Control::kExpertQuery: return IM_COL32(62, 184, 112, alpha);
    case Control::kExpertDemo: return IM_COL32(150, 154, 166, alpha);
    case Control::kExpertTimeout: return IM_COL32(226, 86, 74, alpha);
    case Control::kOperator: return IM_COL32(178, 108, 232, alpha);
  }
  return IM_COL32(255, 255, 255, alpha);
}

Rgba to_rgba(ImU32 c, float alpha = 1.f) {
  const ImVec4 v = ImGui::ColorConvertU32ToFloat4(c);
  return {v.x, v.y, v.z, v.w * alpha};
}

const char* control_label(Control c) {
  switch (c) {
    case Control::kRobot: return "robot";
    case Control::kExpertQuery: return "expert (query)";
    case Control::kExpertDemo: return "expert demo";
    case Control::kExpertTimeout: return "expert (time-out)";
    case Control::kOperator: return "operator";
  }
  return "?";
}

constexpr ImU32 kQueryAmber = IM_COL32(255, 176, 32, 255);
constexpr ImU32 kViolationRed = IM_COL32(240, 70, 70, 255);
constexpr ImU32 kThresholdColor = IM_COL32(255, 176, 32, 255);
constexpr ImU32 kScoreColor = IM_COL32(110, 170, 255, 255);
constexpr ImU32 kGrid = IM_COL32(255, 255, 255, 22);
constexpr ImU32 kAxisText = IM_COL32(200, 204, 214, 170);

ImFont* g_bold = nullptr;
ImFont* g_big = nullptr;

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

struct Decision {
  int index, episode;
  float score, threshold;
  bool violation;
  int run;
  float risk_q;  // thrifty: the critic's min Q (-1: not computed)
};

struct Timeline {
  int episode = 0;
  std::vector<Control> steps;
  bool ended = false, success = false;
};

std::string fmt_seconds(double s) {
  char b[32];
  std::snprintf(b, sizeof b, s < 10 ? "%.1f s" : "%.0f s", s);
  return b;
}

std::string default_out(const std::string& task, const std::string& method) {
  for (int i = 1;; ++i) {
    const std::string d = "out/gui/" + task + "_" + method + "_" + std::to_string(i);
    if (!fs::exists(d)) return d;
  }
}

}  // namespace

struct Console::State {
  ConsoleOptions o;
  std::unique_ptr<Env> env;
  Nav2dEnv* nav = nullptr;
  std::unique_ptr<Expert> scripted;
  std::unique_ptr<ConsoleExpert> expert;
  std::unique_ptr<Method> method;
  std::unique_ptr<DatasetWriter> writer;
  std::unique_ptr<DaggerSession> session;
  std::unique_ptr<EventLog> log;
  std::unique_ptr<Scene2d> scene;
  // the arm tasks: MuJoCo's view, shown through a texture
  mj::ArmEnv* arm = nullptr;
  std::unique_ptr<MujocoView> mjview;
  unsigned mj_tex = 0;
  std::vector<double> mj_key;  // what the texture shows (re-rendered when it changes)
  FreeCamera free_cam;
  int camera = -1;  // -1: the free camera, else the model's camera index
  Eigen::Vector3d op_target{0, 0, 0};
  bool op_valid = false;
  double op_grip = 0, op_yaw = 0, lift = 0;

  // events from the session (either thread), handled on the frame thread
  std::mutex mu;
  std::vector<SessionEvent> queue;

  // the worker: policy updates, the loss field and (windowed runs) the robot's decisions; their
  // results are applied here on the frame thread (ui/worker.h)
  Worker worker;
  MethodDecision decision;  // a decision the worker computed, handed to the session when ready
  double decision_s = 0;
  bool decision_ready = false;
  std::vector<int> deferred_keys;  // session keys pressed while a decision was being computed
  bool busy() const { return worker.busy(); }
  bool updating() const { return worker.busy() && worker.job() != WorkerJob::kDecision; }
  bool deciding() const { return worker.job() == WorkerJob::kDecision; }

  // what the views show
  std::deque<Decision> decisions;
  int decision_count = 0;
  std::deque<Timeline> timelines;
  std::vector<std::pair<Eigen::Vector2d, Control>> path;
  std::vector<std::vector<Eigen::Vector2d>> demo_paths;
  int queries = 0, timeouts = 0, takeovers = 0, robot_episodes = 0, robot_successes = 0, saves = 0;
  UpdateReport last_report;
  double last_decision_ms = 0;

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

namespace {

// The operator drives an arm task: a TCP target that the arrow keys move in the camera's ground
// plane, PageUp/PageDown raise and lower, Shift+drag places; G toggles the gripper.
Vec arm_operator_action(Console::State& s) {
  const mj::ArmEnv& env = *s.arm;
  const Eigen::Vector3d tcp = env.arm().tcp_pos(env.data());
  if (!s.op_valid) {
    s.op_target = tcp;
    s.op_yaw = mj::tool_yaw(env.arm().tcp_rot(env.data()));
    s.op_grip = env.arm().opening(env.data()) < 0.06 ? 1.0 : 0.0;
    s.op_valid = true;
  }
  if (!s.dragging) {
    Eigen::Vector2d fwd(1, 0);
    if (s.camera < 0) {
      const double az = s.free_cam.azimuth * M_PI / 180;
      fwd = Eigen::Vector2d(std::cos(az), std::sin(az));
    }
    const Eigen::Vector2d right(fwd.y(), -fwd.x());
    const Eigen::Vector2d d = (fwd * s.jog.y() + right * s.jog.x()) * 0.01;
    s.op_target += Eigen::Vector3d(d.x(), d.y(), 0.01 * s.lift);
  } else {
    s.op_target.head<2>() = s.drag_target;
  }
  s.op_target.z() = std::clamp(s.op_target.z(), 0.0, 0.5);
  if ((s.op_target - tcp).norm() > 0.08) s.op_target = tcp + (s.op_target - tcp).normalized() * 0.08;  // stay reachable
  const Eigen::Matrix3d R = mj::tool_down(s.op_yaw);
  if (env.control() == mj::ArmControl::kEndEffectorPose) {
    Vec a(10);
    a.head<3>() = s.op_target.cast<float>();
    a.segment<6>(3) = mj::rot6d(R).cast<float>();
    a[9] = static_cast<float>(s.op_grip);
    return a;
  }
  const mj::Vec7 dq = (env.ik_targets(s.op_target, R) - env.arm().q(env.data())).cwiseMax(-env.max_joint_step).cwiseMin(env.max_joint_step);
  return dq.cast<float>();
}

}  // namespace

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
  s.nav = dynamic_cast<Nav2dEnv*>(s.env.get());
  s.arm = dynamic_cast<mj::ArmEnv*>(s.env.get());
  s.scripted = make_expert(c.task, s.o.expert_mode.empty() ? c.expert : s.o.expert_mode);
  s.expert = std::make_unique<ConsoleExpert>(
      *s.scripted, [&s] { return s.operator_drives() && !s.o.scripted_operator; },
      [&s](const Env& env) -> Vec {
        if (s.arm) return arm_operator_action(s);
        // the operator commands a target position: the dragged point, or a step along the jog direction
        const Vec obs = env.observation();
        const Eigen::Vector2d p(obs[0], obs[1]);
        const Eigen::Vector2d t = s.dragging ? s.drag_target : Eigen::Vector2d(p + 0.2 * s.jog);
        return Vec(Eigen::Vector2d(t).cast<float>());
      });
  s.method = make_method(s.o.method, c.policy, c.method, c.dagger.seed);
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
  if (s.arm) {
    s.mjview = std::make_unique<MujocoView>(s.arm->model());
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
int Console::queries() const { return s_->queries; }
int Console::operator_takeovers() const { return s_->takeovers; }
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
  return {{"T", "take over from the robot, or answer its query yourself"},
          {"E", "let the scripted expert answer the query"},
          {"H", "hand control back to the robot"},
          {"Arrow keys", "drive: the target moves with the arrows (arm tasks: in the camera's ground plane)"},
          {"PageUp / PageDown", "arm tasks: raise / lower the target"},
          {"G", "arm tasks: close / open the gripper"},
          {"C", "arm tasks: next camera (free, then the task's cameras)"},
          {"Mouse on an arm scene", "left drag orbits, right drag pans, wheel zooms; Shift + left drag moves the target"},
          {"Left mouse drag", "drag the target in the scene (takes over)"},
          {"Gamepad", "left stick drives; A take over, B hand back, X scripted expert, Start pause"},
          {"Space", "pause / resume"},
          {"N", "single step while paused"},
          {"R", "reset: end this episode (expert steps are kept) and start the next"},
          {"S", "save the policy now (the data set is saved after every episode)"},
          {"F", "show / hide the diffusion-loss field (2-D)"},
          {"+ / -", "faster / slower"},
          {"F12", "screenshot"},
          {"F1 or ?", "this help"},
          {"Esc", "quit (asks when an episode is in progress)"}};
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

// ----------------------------------------------------------------------------------------------
// The frame: events, input, session steps, then the windows.

namespace {

void handle_event(Console::State& s, const SessionEvent& e) {
  (*s.log)(e);
  switch (e.kind) {
    case EventKind::kEpisodeStart:
      s.timelines.push_back({e.episode, {}, false, false});
      while (s.timelines.size() > 64) s.timelines.pop_front();
      s.path.clear();
      s.answering = Console::State::Answer::kNobody;
      s.awaiting = false;
      s.dragging = false;
      break;
    case EventKind::kDecision:
      s.decisions.push_back({s.decision_count++, e.episode, e.score, e.threshold, e.violation, e.run, e.risk_q});
      while (s.decisions.size() > 400) s.decisions.pop_front();
      s.last_decision_ms = e.inference_s * 1e3;
      break;
    case EventKind::kQuery:
      ++s.queries;
      if (s.o.pause_on_query) {
        s.awaiting = true;
        s.answering = Console::State::Answer::kNobody;
        if (s.o.scripted_operator) s.operator_countdown = s.o.operator_delay;
      } else {
        s.answering = Console::State::Answer::kScripted;
      }
      s.request_shot("query");
      break;
    case EventKind::kTakeover:
      if (e.control == Control::kOperator) {
        ++s.takeovers;
        s.op_valid = false;
        s.answering = Console::State::Answer::kOperator;
        s.takeover_steps = 0;
      } else if (e.control == Control::kExpertTimeout) {
        ++s.timeouts;
        s.answering = Console::State::Answer::kScripted;
      }
      break;
    case EventKind::kHandBack:
      s.answering = Console::State::Answer::kNobody;
      s.awaiting = false;
      s.dragging = false;
      break;
    case EventKind::kEpisodeEnd:
      if (!s.timelines.empty()) {
        s.timelines.back().ended = true;
        s.timelines.back().success = e.success;
      }
      if (e.control == Control::kRobot && !s.session->expert_acted()) {
        ++s.robot_episodes;
        if (e.success) ++s.robot_successes;
      }
      s.awaiting = false;
      if (s.takeover_steps >= 0) s.request_shot("takeover");
      s.takeover_steps = -1;
      break;
    case EventKind::kUpdateFinished:
      s.last_report = e.report;
      s.field_valid = false;
      s.update_shot_due = true;  // taken once the worker is idle (the checkpoint is written)
      break;
    case EventKind::kDone: s.status = "done: N_f expert demonstrations reached"; break;
    default: break;
  }
}

void drain(Console::State& s) {
  std::vector<SessionEvent> events;
  {
    std::lock_guard<std::mutex> lock(s.mu);
    events.swap(s.queue);
  }
  for (const auto& e : events) handle_event(s, e);
}

void start_update(Console::State& s) {
  const std::string dir = s.o.out + "/checkpoints/update_" + std::to_string(s.session->updates() + 1);
  s.worker.start(WorkerJob::kUpdate, [&s, dir](std::atomic<float>& progress) -> Worker::Apply {
    const UpdateReport report =
        s.session->compute_update([&progress](int done, int total, double) { progress = total > 0 ? float(done) / total : 1.f; });
    fs::create_directories(dir);
    s.method->save(dir);
    return [&s, report] { s.session->finish_update(report); };
  });
}

// The method's score over a grid of positions at rest (the obstacle where it is this episode).
void start_field(Console::State& s) {
  if (!s.nav || s.session->updates() == 0) return;
  const Eigen::Vector2d center = s.nav->obstacle_center();
  const int n = s.field_n, obs_dim = s.env->obs_dim();
  const Nav2dEnv& nav = *s.nav;
  Method& method = *s.method;
  s.worker.start(WorkerJob::kField, [&s, &nav, &method, center, n, obs_dim](std::atomic<float>& progress) -> Worker::Apply {
    const double half = nav.config().arena_half;
    std::vector<float> logs(static_cast<size_t>(n * n), NAN);
    for (int j = 0; j < n; ++j) {
      for (int i = 0; i < n; ++i) {
        const Eigen::Vector2d p(-half + (i + 0.5) * 2 * half / n, -half + (j + 0.5) * 2 * half / n);
        if (!nav.is_free(p)) continue;
        Vec obs = Vec::Zero(obs_dim);
        obs[0] = static_cast<float>(p.x());
        obs[1] = static_cast<float>(p.y());
        if (obs.size() >= 6) {
          obs[4] = static_cast<float>(center.x());
          obs[5] = static_cast<float>(center.y());
        }
        const float score = method.decide(obs, 17 + static_cast<uint64_t>(j * n + i)).score;
        logs[static_cast<size_t>(j * n + i)] = std::log(std::max(score, 1e-12f));
      }
      progress = float(j + 1) / n;
    }
    std::vector<float> finite;
    for (float v : logs)
      if (std::isfinite(v)) finite.push_back(v);
    std::sort(finite.begin(), finite.end());
    const float lo = finite.empty() ? 0 : finite[finite.size() / 50], hi = finite.empty() ? 1 : finite[finite.size() * 49 / 50];
    for (float& v : logs) v = std::isfinite(v) ? std::clamp((v - lo) / std::max(hi - lo, 1e-6f), 0.f, 1.f) : 0.f;
    return [&s, logs = std::move(logs)]() mutable {
      s.field = std::move(logs);
      s.field_valid = true;
    };
  });
}

void save_policy(Console::State& s) {
  if (s.session->updates() == 0) {
    s.status = "nothing to save yet: the policy has not been trained";
    return;
  }
  const std::string dir = s.o.out + "/checkpoints/manual_" + std::to_string(++s.saves);
  fs::create_directories(dir);
  s.method->save(dir);
  s.log->note("save", dir);
  s.status = "saved the policy to " + dir;
}

void answer_as_operator(Console::State& s) {
  s.answering = Console::State::Answer::kOperator;
  s.op_valid = false;
  s.awaiting = false;
  s.takeover_steps = 0;
  s.operator_countdown = -1;
  s.session->operator_answers_query();  // the data set labels these steps the operator's
  ++s.takeovers;                         // and the console shows and counts them as the operator's
  s.log->note("operator_answers", "episode " + std::to_string(s.session->episode()));
}

void take_over(Console::State& s) {
  if (s.awaiting) {
    answer_as_operator(s);
  } else if (s.session->take_over()) {
    drain(s);
  }
}

void handle_key(Console::State& s, int key) {
  const bool session_key = key == GLFW_KEY_T || key == GLFW_KEY_H || key == GLFW_KEY_R || key == GLFW_KEY_S || key == GLFW_KEY_E;
  if (s.deciding() && session_key) {  // acted on as soon as the decision is in
    s.deferred_keys.push_back(key);
    return;
  }
  const bool idle = !s.busy();
  switch (key) {
    case GLFW_KEY_T: if (idle) take_over(s); break;
    case GLFW_KEY_E:
      if (s.awaiting) {
        s.answering = Console::State::Answer::kScripted;
        s.awaiting = false;
        s.log->note("scripted_expert_answers", "episode " + std::to_string(s.session->episode()));
      }
      break;
    case GLFW_KEY_H:
      if (idle && s.session->hand_back()) drain(s);
      break;
    case GLFW_KEY_SPACE: s.paused = !s.paused; break;
    case GLFW_KEY_N: s.paused = true; s.step_once = true; break;
    case GLFW_KEY_R:
      if (idle && s.session->in_episode()) {
        s.session->end_episode_now();
        s.log->note("reset", "episode " + std::to_string(s.session->episode()));
        drain(s);
      }
      break;
    case GLFW_KEY_S: if (idle) save_policy(s); break;
    case GLFW_KEY_G: s.op_grip = s.op_grip > 0.5 ? 0.0 : 1.0; break;
    case GLFW_KEY_C:
      if (s.arm) {
        const int n = s.arm->model()->ncam;
        s.camera = s.camera + 1 >= n ? -1 : s.camera + 1;
      }
      break;
    case GLFW_KEY_F:
      s.show_field = !s.show_field;
      if (s.show_field && !s.field_valid) s.field_wanted = true;
      break;
    case GLFW_KEY_EQUAL: case GLFW_KEY_KP_ADD: s.o.speed = std::min(s.o.speed * 2, 16.0); break;
    case GLFW_KEY_MINUS: case GLFW_KEY_KP_SUBTRACT: s.o.speed = std::max(s.o.speed / 2, 0.125); break;
    case GLFW_KEY_F1: case GLFW_KEY_SLASH: s.show_help = !s.show_help; break;
    case GLFW_KEY_F12: s.shots.push_back("screenshot_" + std::to_string(++s.screenshot_count)); break;
    case GLFW_KEY_ENTER: case GLFW_KEY_KP_ENTER:
      if (s.close_dialog) {
        s.close_dialog = false;
        s.quitting = true;
      }
      break;
    case GLFW_KEY_ESCAPE:
      if (s.close_dialog) s.close_dialog = false;
      else if (s.show_help) s.show_help = false;
      else if (s.session->in_episode() && s.session->expert_acted()) s.close_dialog = true;
      else s.quitting = true;
      break;
    default: break;
  }
}

// Steps the session as far as this frame allows.
void advance(Console::State& s, double dt) {
  if (!s.worker.error().empty()) return;
  if (s.busy()) return;
  if (s.session->done()) return;
  if (s.session->update_pending()) {
    start_update(s);
    return;
  }
  if (s.field_wanted) {
    s.field_wanted = false;
    start_field(s);
    return;
  }
  if (s.awaiting) {
    if (s.operator_countdown > 0 && --s.operator_countdown == 0) answer_as_operator(s);
    return;
  }
  int ticks = 0;
  if (s.paused) {
    ticks = s.step_once ? 1 : 0;
    s.step_once = false;
  } else if (s.o.fixed_step) {
    ticks = 1;
  } else {
    s.tick_budget = std::min(s.tick_budget + dt * s.env->control_hz() * s.o.speed, 8.0);
    ticks = static_cast<int>(s.tick_budget);
    s.tick_budget -= ticks;
  }
  for (int i = 0; i < ticks; ++i) {
    if (!s.o.fixed_step) {
      // the robot's decisions run on the worker so that the window keeps drawing (headless runs
      // decide inline: same results, one frame per step)
      if (s.decision_ready) {
        s.decision_ready = false;
        std::vector<int> keys;
        keys.swap(s.deferred_keys);
        for (int k : keys) handle_key(s, k);
        if (s.session->decision_due()) s.session->provide_decision(std::move(s.decision), s.decision_s);
      } else {
        s.session->prepare();
        drain(s);
        if (s.session->decision_due()) {
          const Vec obs = s.env->observation();
          const uint64_t seed = s.session->next_decision_seed();
          Method& method = *s.method;
          s.worker.start(WorkerJob::kDecision, [&s, &method, obs, seed](std::atomic<float>&) -> Worker::Apply {
            const auto t = std::chrono::steady_clock::now();
            MethodDecision d = method.decide(obs, seed);
            const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
            return [&s, d = std::move(d), took]() mutable {
              s.decision = std::move(d);
              s.decision_s = took;
              s.decision_ready = true;
            };
          });
          break;
        }
      }
    }
    s.session->tick();
    const Control used = s.session->actor();  // who acted in this step (the operator when answering a query)
    drain(s);
    if (s.nav) s.path.emplace_back(s.nav->position(), used);
    if (!s.timelines.empty() && s.timelines.back().episode == s.session->episode()) s.timelines.back().steps.push_back(used);
    if (s.takeover_steps >= 0 && ++s.takeover_steps == 20) s.request_shot("takeover");
    if (s.session->update_pending() || s.awaiting || s.session->done()) break;
  }
}

// ---- views ----

void draw_nav2d(Console::State& s, ImVec2 size) {
  Scene2d& sc = *s.scene;
  const int px = std::max(64, static_cast<int>(std::min(size.x, size.y)));
  sc.resize(px, px);
  const Nav2dConfig& c = s.nav->config();
  const double half = c.arena_half;
  sc.begin({0, 0}, half + 0.06, {0.075f, 0.080f, 0.095f, 1.f});
  sc.rect({-half - 0.04, -half - 0.04}, {half + 0.04, half + 0.04}, {0.30f, 0.32f, 0.37f, 1.f});  // walls
  sc.rect({-half, -half}, {half, half}, {0.145f, 0.155f, 0.180f, 1.f});                            // floor
  if (s.show_field && s.field_valid)
    sc.heat(s.field, s.field_n, s.field_n, {-half, -half}, {half, half}, 0.85f);
  // start square and goal
  const Eigen::Vector2d sh(c.start_half, c.start_half);
  sc.stroke({c.start_center - sh, c.start_center + Eigen::Vector2d(c.start_half, -c.start_half), c.start_center + sh,
             c.start_center + Eigen::Vector2d(-c.start_half, c.start_half), c.start_center - sh},
            1.5, {1, 1, 1, 0.35f});
  sc.disc(c.goal, c.goal_radius, {0.30f, 0.78f, 0.45f, 0.35f});
  sc.ring(c.goal, c.goal_radius, 2.0, {0.35f, 0.85f, 0.50f, 0.9f});
  // demonstrations (the newest 40)
  const auto& demos = s.session->expert_data();
  const size_t from = demos.size() > 40 ? demos.size() - 40 : 0;
  for (size_t d = from; d < demos.size(); ++d) {
    std::vector<Eigen::Vector2d> pts;
    for (Eigen::Index t = 0; t < demos[d].obs.rows(); ++t) pts.emplace_back(demos[d].obs(t, 0), demos[d].obs(t, 1));
    sc.stroke(pts, 1.6, {0.80f, 0.84f, 0.95f, 0.22f});
  }
  sc.disc(s.nav->obstacle_center(), c.obstacle_radius, {0.40f, 0.42f, 0.49f, 1.f}, 0.06f);
  // the executed path, coloured by who was in control
  for (size_t i = 1; i < s.path.size(); ++i)
    sc.stroke({s.path[i - 1].first, s.path[i].first}, 3.0, to_rgba(control_color(s.path[i].second)));
  // the planned chunk: targets ahead of the robot, executed ones faded
  const Mat& chunk = s.session->chunk();
  if (chunk.rows() > 0 && s.session->control() == Control::kRobot) {
    std::vector<Eigen::Vector2d> pts;
    for (Eigen::Index r = 0; r < chunk.rows(); ++r) pts.emplace_back(chunk(r, 0), chunk(r, 1));
    sc.stroke(pts, 1.5, {0.55f, 0.85f, 1.f, 0.6f});
    for (Eigen::Index r = 0; r < chunk.rows(); ++r)
      sc.dot(pts[static_cast<size_t>(r)], 3.0, {0.55f, 0.85f, 1.f, r < s.session->chunk_pos() ? 0.3f : 0.95f});
  }
  if (s.operator_drives() && !s.o.scripted_operator) {
    const Eigen::Vector2d p = s.nav->position();
    const Eigen::Vector2d t = s.dragging ? s.drag_target : Eigen::Vector2d(p + 0.2 * s.jog);
    sc.stroke({p, t}, 1.5, to_rgba(control_color(Control::kOperator), 0.8f));
    sc.ring(t, 0.035, 2.0, to_rgba(control_color(Control::kOperator)));
  }
  const Control now = s.session->in_episode() ? s.session->actor() : s.path.empty() ? Control::kRobot : s.path.back().second;
  sc.disc(s.nav->position(), c.agent_radius + 0.012, {1, 1, 1, 0.9f});
  sc.disc(s.nav->position(), c.agent_radius, to_rgba(control_color(now)));
  sc.render();
}

// The arm scene through MuJoCo's renderer: the free camera (orbit, pan, zoom with the mouse) or one
// of the task's cameras; the robot's planned TCP positions and the operator's target as markers.
void draw_mujoco(Console::State& s, ImVec2 origin, float side) {
  const mjData* d = s.arm->data();
  std::vector<Marker> markers;
  const Mat& chunk = s.session->chunk();
  if (chunk.rows() > 0 && chunk.cols() >= 3 && s.arm->control() == mj::ArmControl::kEndEffectorPose &&
      s.session->control() == Control::kRobot)
    for (Eigen::Index r = 0; r < chunk.rows(); ++r) {
      const float a = r < s.session->chunk_pos() ? 0.25f : 0.9f;
      markers.push_back({{chunk(r, 0), chunk(r, 1), chunk(r, 2)}, 0.006, {0.45f, 0.8f, 1.f, a}});
    }
  if (s.operator_drives() && !s.o.scripted_operator && s.op_valid)
    markers.push_back({{s.op_target.x(), s.op_target.y(), s.op_target.z()}, 0.012, {0.7f, 0.42f, 0.91f, 0.9f}});
  const int px = std::max(64, static_cast<int>(side));
  // MuJoCo's renderer is the costly part of a frame on a software GL: render only when the picture
  // changes (the simulation stepped, the camera or a marker moved), not while a policy update runs
  std::vector<double> key = {d->time, s.free_cam.lookat[0], s.free_cam.lookat[1], s.free_cam.lookat[2], s.free_cam.distance,
                             s.free_cam.azimuth, s.free_cam.elevation, double(s.camera), double(px), double(markers.size())};
  for (const Marker& m : markers) key.insert(key.end(), {m.pos[0], m.pos[1], m.pos[2], double(m.rgba[3])});
  if (key != s.mj_key) {
    s.mj_key = key;
    const Image img = s.camera < 0 ? s.mjview->free(d, s.free_cam, px, px, markers)
                                   : s.mjview->camera_view(d, mj_id2name(s.arm->model(), mjOBJ_CAMERA, s.camera), px, px, markers);
    glBindTexture(GL_TEXTURE_2D, s.mj_tex);
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, img.width, img.height, 0, GL_RGBA, GL_UNSIGNED_BYTE, img.rgba.data());
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  }
  ImGui::SetCursorScreenPos(origin);
  ImGui::Image(reinterpret_cast<ImTextureID>(static_cast<intptr_t>(s.mj_tex)), ImVec2(side, side));
  const bool hovered = ImGui::IsItemHovered();
  ImGuiIO& io = ImGui::GetIO();
  if (hovered && s.camera < 0) {
    if (io.KeyShift && ImGui::IsMouseDown(ImGuiMouseButton_Left) && !s.busy()) {
      // Shift + drag: the operator's target follows the point under the mouse
      const ImVec2 m = ImGui::GetMousePos();
      double p[3];
      if (s.mjview->select(d, (m.x - origin.x) / side, 1.0 - (m.y - origin.y) / side, 1.0, p)) {
        s.drag_target = Eigen::Vector2d(p[0], p[1]);
        if (!s.dragging) {
          s.dragging = true;
          if (!s.operator_drives()) take_over(s);
        }
      }
    } else if (ImGui::IsMouseDragging(ImGuiMouseButton_Left)) {
      s.free_cam.azimuth -= io.MouseDelta.x * 0.3;
      s.free_cam.elevation = std::clamp(s.free_cam.elevation - io.MouseDelta.y * 0.3, -89.0, -2.0);
    } else if (ImGui::IsMouseDragging(ImGuiMouseButton_Right)) {
      const double az = s.free_cam.azimuth * M_PI / 180, k = s.free_cam.distance * 0.0015;
      s.free_cam.lookat[0] += (-std::sin(az) * io.MouseDelta.x - std::cos(az) * io.MouseDelta.y) * k;
      s.free_cam.lookat[1] += (std::cos(az) * io.MouseDelta.x - std::sin(az) * io.MouseDelta.y) * k;
    }
    if (io.MouseWheel != 0) s.free_cam.distance = std::clamp(s.free_cam.distance * (1.0 - 0.1 * io.MouseWheel), 0.3, 5.0);
  }
  if (!ImGui::IsMouseDown(ImGuiMouseButton_Left)) s.dragging = false;
  // which camera, top-left
  const char* cam = s.camera < 0 ? "free camera (C: next)" : mj_id2name(s.arm->model(), mjOBJ_CAMERA, s.camera);
  ImDrawList* dl = ImGui::GetWindowDrawList();
  const ImVec2 ts = ImGui::CalcTextSize(cam);
  dl->AddRectFilled(ImVec2(origin.x + 8, origin.y + side - 30), ImVec2(origin.x + 20 + ts.x, origin.y + side - 8),
                    IM_COL32(10, 12, 16, 170), 4.f);
  dl->AddText(ImVec2(origin.x + 14, origin.y + side - 27), IM_COL32(220, 224, 232, 230), cam);
}

// A fixed panel of the console's layout (closed with ImGui::End()).
void begin_panel(const char* title, ImVec2 pos, ImVec2 size, ImGuiWindowFlags extra = 0) {
  ImGui::SetNextWindowPos(pos);
  ImGui::SetNextWindowSize(size);
  ImGui::Begin(title, nullptr,
               ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoCollapse | ImGuiWindowFlags_NoSavedSettings | extra);
}

void scene_view(Console::State& s, ImVec2 pos, ImVec2 size) {
  begin_panel("Scene", pos, size, ImGuiWindowFlags_NoScrollbar);
  const ImVec2 avail = ImGui::GetContentRegionAvail();
  const float side = std::min(avail.x, avail.y - 58);  // room for the legend below
  const ImVec2 origin(ImGui::GetCursorScreenPos().x + (avail.x - side) * 0.5f, ImGui::GetCursorScreenPos().y);
  ImDrawList* dl = ImGui::GetWindowDrawList();
  if (s.nav) {
    draw_nav2d(s, ImVec2(side, side));
    ImGui::SetCursorScreenPos(origin);
    ImGui::Image(reinterpret_cast<ImTextureID>(static_cast<intptr_t>(s.scene->texture())), ImVec2(side, side), ImVec2(0, 1),
                 ImVec2(1, 0));
    // dragging a target takes over and steers
    if (ImGui::IsItemHovered() && ImGui::IsMouseDown(ImGuiMouseButton_Left) && !s.busy()) {
      const ImVec2 m = ImGui::GetMousePos();
      const double k = s.scene->width() / double(side);
      s.drag_target = s.scene->pixel_to_world((m.x - origin.x) * k, (m.y - origin.y) * k);
      if (!s.dragging) {
        s.dragging = true;
        if (!s.operator_drives()) take_over(s);
      }
    } else if (!ImGui::IsMouseDown(ImGuiMouseButton_Left)) {
      s.dragging = false;
    }
  } else if (s.arm) {
    draw_mujoco(s, origin, side);
  } else {
    dl->AddText(origin, kAxisText, "no renderer for this task");
  }
  // legend and key hints below the scene
  {
    ImVec2 p(origin.x + 4, origin.y + side + 10);
    const Control order[] = {Control::kRobot, Control::kExpertQuery, Control::kOperator, Control::kExpertTimeout,
                             Control::kExpertDemo};
    for (Control c : order) {
      dl->AddRectFilled(ImVec2(p.x, p.y + 4), ImVec2(p.x + 12, p.y + 14), control_color(c), 2.f);
      dl->AddText(ImVec2(p.x + 17, p.y), IM_COL32(220, 224, 232, 230), control_label(c));
      p.x += 22 + ImGui::CalcTextSize(control_label(c)).x + 12;
    }
    dl->AddText(ImVec2(origin.x + 4, origin.y + side + 34), kAxisText,
                s.show_field && s.field_valid
                    ? "loss field (the method's score at rest, log scale): dark = familiar, bright = unfamiliar"
                    : "T take over   H hand back   E scripted expert   Space pause   F loss field   F1 all keys");
  }
  // the query banner: the robot waits for the operator
  if (s.awaiting) {
    const float w = side - 40, h = 92;
    const ImVec2 a(origin.x + 20, origin.y + 20), b(a.x + w, a.y + h);
    const bool blink = std::fmod(ImGui::GetTime(), 1.0) < 0.5 || s.o.fixed_step;
    dl->AddRectFilled(a, b, IM_COL32(200, 40, 40, blink ? 235 : 200), 8.f);
    dl->AddRect(a, b, IM_COL32(255, 210, 120, 255), 8.f, 0, 3.f);
    if (g_big) ImGui::PushFont(g_big);
    const char* title = "THE ROBOT ASKS FOR HELP";
    const ImVec2 ts = ImGui::CalcTextSize(title);
    dl->AddText(ImVec2(a.x + (w - ts.x) * 0.5f, a.y + 12), IM_COL32(255, 255, 255, 255), title);
    if (g_big) ImGui::PopFont();
    char line[160];
    const Decision* d = s.decisions.empty() ? nullptr : &s.decisions.back();
    const float score = d ? d->score : 0.f, threshold = d ? d->threshold : 0.f;
    const int K = s.o.config.dagger.patience;
    if (s.o.method == "diff")
      std::snprintf(line, sizeof line, "loss %.3g above the threshold %.3g for %d decisions in a row", score, threshold, K);
    else if (score > threshold)
      std::snprintf(line, sizeof line, "novelty: ensemble variance %.3g above %.3g for %d decisions in a row", score, threshold, K);
    else
      std::snprintf(line, sizeof line, "risk: the critic's success estimate %.2f is below its bound", d ? d->risk_q : 0.f);
    ImVec2 ls = ImGui::CalcTextSize(line);
    dl->AddText(ImVec2(a.x + (w - ls.x) * 0.5f, a.y + 44), IM_COL32(255, 235, 220, 255), line);
    const char* keys = s.o.scripted_operator ? "the scripted operator takes over shortly"
                                             : "T: take over    E: scripted expert    Esc: quit";
    ls = ImGui::CalcTextSize(keys);
    dl->AddText(ImVec2(a.x + (w - ls.x) * 0.5f, a.y + 66), IM_COL32(255, 255, 255, 255), keys);
  } else if (s.updating()) {
    const float w = 300, h = 54;
    const ImVec2 a(origin.x + (side - w) * 0.5f, origin.y + 20), b(a.x + w, a.y + h);
    dl->AddRectFilled(a, b, IM_COL32(18, 22, 30, 225), 8.f);
    char line[96];
    std::snprintf(line, sizeof line, "%s %d%%", s.worker.job() == WorkerJob::kUpdate ? "Updating the policy" : "Computing the loss field",
                  static_cast<int>(s.worker.progress() * 100));
    dl->AddText(ImVec2(a.x + 14, a.y + 8), IM_COL32(230, 234, 240, 255), line);
    dl->AddRectFilled(ImVec2(a.x + 14, a.y + 32), ImVec2(b.x - 14, a.y + 42), IM_COL32(60, 66, 80, 255), 3.f);
    dl->AddRectFilled(ImVec2(a.x + 14, a.y + 32), ImVec2(a.x + 14 + (w - 28) * s.worker.progress(), a.y + 42), IM_COL32(72, 132, 235, 255),
                      3.f);
  } else if (s.operator_drives() && !s.o.scripted_operator) {
    const char* t = "You are driving: arrow keys, or drag the target.  H hands back to the robot.";
    const ImVec2 ts = ImGui::CalcTextSize(t);
    dl->AddRectFilled(ImVec2(origin.x + (side - ts.x) * 0.5f - 10, origin.y + 14),
                      ImVec2(origin.x + (side + ts.x) * 0.5f + 10, origin.y + 40), IM_COL32(120, 70, 170, 220), 6.f);
    dl->AddText(ImVec2(origin.x + (side - ts.x) * 0.5f, origin.y + 19), IM_COL32(255, 255, 255, 255), t);
  }
  if (s.show_field && !s.field_valid && !s.updating()) {
    const char* t = s.session->updates() == 0 ? "the loss field needs a trained policy" : "press F again to compute the field";
    dl->AddText(ImVec2(origin.x + 12, origin.y + 12), kAxisText, t);
  }
  ImGui::End();
}

// Expected loss (or the method's score) per decision on a log axis, with the threshold and violations.
void loss_plot(Console::State& s, ImVec2 pos, ImVec2 size) {
  begin_panel(s.o.method == "diff" ? "Expected diffusion loss per decision###plot" : "Query score per decision###plot", pos, size);
  const Decision* last = s.decisions.empty() ? nullptr : &s.decisions.back();
  if (last) {
    ImGui::TextColored(ImVec4(0.55f, 0.75f, 1.f, 1.f), "score %.4g", last->score);
    ImGui::SameLine(0, 18);
    ImGui::TextColored(ImVec4(1.f, 0.70f, 0.15f, 1.f), "threshold %.4g (alpha %.2f)", last->threshold, s.o.config.method.alpha);
    ImGui::SameLine(0, 18);
    const int K = s.o.config.dagger.patience;
    ImGui::TextColored(last->run > 0 ? ImVec4(1.f, 0.35f, 0.35f, 1.f) : ImVec4(0.7f, 0.72f, 0.78f, 1.f), "in a row: %d / K=%d",
                       last->run, K);
  } else {
    ImGui::TextDisabled("no robot decisions yet: the expert demonstrates first");
  }
  ImDrawList* dl = ImGui::GetWindowDrawList();
  const ImVec2 avail = ImGui::GetContentRegionAvail();
  const ImVec2 p0 = ImGui::GetCursorScreenPos();
  const float left = 52, bottom = 20;
  const ImVec2 a(p0.x + left, p0.y + 4), b(p0.x + avail.x - 6, p0.y + avail.y - bottom);
  dl->AddRectFilled(a, b, IM_COL32(14, 16, 21, 255), 4.f);
  ImGui::Dummy(avail);
  if (s.decisions.empty() || b.x - a.x < 20) {
    ImGui::End();
    return;
  }
  const int window = 120;
  const int n = static_cast<int>(s.decisions.size());
  const int first = std::max(0, n - window);
  float lo = INFINITY, hi = -INFINITY;
  for (int i = first; i < n; ++i) {
    const Decision& d = s.decisions[static_cast<size_t>(i)];
    for (float v : {d.score, d.threshold})
      if (v > 0 && std::isfinite(v)) {
        lo = std::min(lo, std::log10(v));
        hi = std::max(hi, std::log10(v));
      }
  }
  if (!std::isfinite(lo)) lo = -3, hi = 0;
  lo = std::floor(lo - 0.15f);
  hi = std::ceil(hi + 0.15f);
  if (hi - lo < 1) hi = lo + 1;
  auto X = [&](int i) { return a.x + 6 + (b.x - a.x - 12) * float(i - first) / float(std::max(window - 1, 1)); };
  auto Y = [&](float v) {
    const float l = std::log10(std::max(v, 1e-12f));
    return b.y - (b.y - a.y) * (l - lo) / (hi - lo);
  };
  for (int e = static_cast<int>(lo); e <= static_cast<int>(hi); ++e) {
    const float y = b.y - (b.y - a.y) * (e - lo) / (hi - lo);
    dl->AddLine(ImVec2(a.x, y), ImVec2(b.x, y), kGrid);
    char t[16];
    std::snprintf(t, sizeof t, "1e%d", e);
    dl->AddText(ImVec2(p0.x + 6, y - 8), kAxisText, t);
  }
  // episode boundaries
  for (int i = first + 1; i < n; ++i)
    if (s.decisions[static_cast<size_t>(i)].episode != s.decisions[static_cast<size_t>(i - 1)].episode)
      dl->AddLine(ImVec2(X(i) - 0.5f * (X(1) - X(0)), a.y), ImVec2(X(i) - 0.5f * (X(1) - X(0)), b.y), IM_COL32(255, 255, 255, 30));
  dl->PushClipRect(a, b, true);
  for (int i = first + 1; i < n; ++i) {
    const Decision& d0 = s.decisions[static_cast<size_t>(i - 1)];
    const Decision& d1 = s.decisions[static_cast<size_t>(i)];
    dl->AddLine(ImVec2(X(i - 1), Y(d0.threshold)), ImVec2(X(i), Y(d0.threshold)), kThresholdColor, 2.f);
    dl->AddLine(ImVec2(X(i), Y(d0.threshold)), ImVec2(X(i), Y(d1.threshold)), kThresholdColor, 2.f);
    if (d0.episode == d1.episode) dl->AddLine(ImVec2(X(i - 1), Y(d0.score)), ImVec2(X(i), Y(d1.score)), kScoreColor, 2.f);
  }
  for (int i = first; i < n; ++i) {
    const Decision& d = s.decisions[static_cast<size_t>(i)];
    if (d.violation) {
      dl->AddCircleFilled(ImVec2(X(i), Y(d.score)), 4.5f, kViolationRed);
      if (d.run >= s.o.config.dagger.patience) {
        dl->AddLine(ImVec2(X(i), a.y), ImVec2(X(i), b.y), IM_COL32(255, 176, 32, 120), 1.5f);
        dl->AddText(ImVec2(X(i) + 3, a.y + 2), kQueryAmber, "query");
      }
    } else {
      dl->AddCircleFilled(ImVec2(X(i), Y(d.score)), 2.5f, kScoreColor);
    }
  }
  dl->PopClipRect();
  char t[48];
  std::snprintf(t, sizeof t, "decision %d", s.decisions.back().index + 1);
  dl->AddText(ImVec2(b.x - ImGui::CalcTextSize(t).x, b.y + 2), kAxisText, t);
  dl->AddText(ImVec2(a.x, b.y + 2), kAxisText, "last 120 decisions; red: above threshold");
  ImGui::End();
}

// One row per episode, one cell per step, coloured by who was in control.
void timeline_view(Console::State& s, ImVec2 pos, ImVec2 size) {
  begin_panel("Control per episode", pos, size);
  ImDrawList* dl = ImGui::GetWindowDrawList();
  const ImVec2 avail = ImGui::GetContentRegionAvail();
  const ImVec2 p0 = ImGui::GetCursorScreenPos();
  ImGui::Dummy(avail);
  const float row_h = 15, gap = 4, label_w = 44;
  const int rows = std::max(1, static_cast<int>((avail.y - 18) / (row_h + gap)));
  const int n = static_cast<int>(s.timelines.size());
  const int first = std::max(0, n - rows);
  const int T = s.o.config.dagger.expert_time_limit > 0 ? s.o.config.dagger.expert_time_limit : 2 * s.o.config.dagger.time_limit;
  const float w = avail.x - label_w - 36;
  for (int r = first; r < n; ++r) {
    const Timeline& tl = s.timelines[static_cast<size_t>(r)];
    const float y = p0.y + (r - first) * (row_h + gap);
    char t[16];
    std::snprintf(t, sizeof t, "#%d", tl.episode);
    dl->AddText(ImVec2(p0.x, y), kAxisText, t);
    const float x0 = p0.x + label_w;
    dl->AddRectFilled(ImVec2(x0, y + 1), ImVec2(x0 + w, y + row_h - 1), IM_COL32(255, 255, 255, 12), 2.f);
    size_t i = 0;
    while (i < tl.steps.size()) {
      size_t j = i;
      while (j < tl.steps.size() && tl.steps[j] == tl.steps[i]) ++j;
      const float xa = x0 + w * float(i) / T, xb = x0 + w * std::min(float(j) / T, 1.f);
      dl->AddRectFilled(ImVec2(xa, y + 1), ImVec2(std::max(xb, xa + 1), y + row_h - 1), control_color(tl.steps[i]));
      i = j;
    }
    if (tl.ended)
      dl->AddText(ImVec2(x0 + w + 8, y), tl.success ? IM_COL32(110, 220, 140, 255) : IM_COL32(240, 90, 90, 255),
                  tl.success ? "ok" : "fail");
  }
  char t[64];
  std::snprintf(t, sizeof t, "steps (0 .. %d; the robot's limit T_L = %d)", T, s.o.config.dagger.time_limit);
  dl->AddText(ImVec2(p0.x + label_w, p0.y + avail.y - 16), kAxisText, t);
  const float xl = p0.x + label_w + w * float(s.o.config.dagger.time_limit) / T;
  dl->AddLine(ImVec2(xl, p0.y), ImVec2(xl, p0.y + std::min(n - first, rows) * (row_h + gap)), IM_COL32(226, 86, 74, 140), 1.f);
  ImGui::End();
}

void stat_row(const char* label, const std::string& value) {
  ImGui::TextDisabled("%s", label);
  ImGui::SameLine(0, 0);
  ImGui::SetCursorPosX(ImGui::GetColumnOffset() + 128);
  ImGui::TextUnformatted(value.c_str());
}

void session_view(Console::State& s, ImVec2 pos, ImVec2 size) {
  begin_panel("Session", pos, size);
  const DaggerSession& se = *s.session;
  const DaggerConfig& d = s.o.config.dagger;
  ImGui::Columns(2, nullptr, false);
  stat_row("episode", std::to_string(se.episode()) + (se.in_episode() ? ", step " + std::to_string(s.env->steps()) : ""));
  stat_row("expert demos", std::to_string(se.expert_demos()) + " / " + std::to_string(d.final_demos) + " (N_f)");
  stat_row("interventions", std::to_string(se.interventions()) + " (update every " + std::to_string(d.demos_per_update) + ")");
  stat_row("queries", std::to_string(s.queries) + ", time-outs " + std::to_string(s.timeouts));
  stat_row("takeovers", std::to_string(s.takeovers) + " by the operator");
  stat_row("robot alone", std::to_string(s.robot_successes) + " / " + std::to_string(s.robot_episodes) + " succeeded");
  ImGui::NextColumn();
  stat_row("updates", std::to_string(se.updates()));
  stat_row("training pairs", se.updates() ? std::to_string(s.last_report.pairs) : "-");
  char b[64];
  std::snprintf(b, sizeof b, "%.4g", s.last_report.threshold);
  stat_row("threshold", se.updates() ? b : "-");
  stat_row("train / thresh.", se.updates() ? fmt_seconds(s.last_report.train_s) + " / " + fmt_seconds(s.last_report.threshold_s) : "-");
  std::snprintf(b, sizeof b, "%.0f ms", s.last_decision_ms);
  stat_row("decision time", s.decisions.empty() ? "-" : b);
  if (s.o.fixed_step) std::snprintf(b, sizeof b, "fixed step %.0f ms", 1e3 / s.env->control_hz());
  else std::snprintf(b, sizeof b, "%.1f ms, speed x%g", s.frame_ms, s.o.speed);
  stat_row("frame", b);
  ImGui::Columns(1);
  ImGui::Separator();
  if (s.updating()) {
    char label[64];
    std::snprintf(label, sizeof label, "%s %d%%", to_string(s.worker.job()), static_cast<int>(s.worker.progress() * 100));
    ImGui::ProgressBar(s.worker.progress(), ImVec2(-1, 0), label);
  } else if (!s.worker.error().empty()) {
    ImGui::TextColored(ImVec4(1, 0.4f, 0.4f, 1), "worker failed: %s", s.worker.error().c_str());
  } else if (!s.status.empty()) {
    ImGui::TextWrapped("%s", s.status.c_str());
  } else {
    ImGui::TextDisabled("data set: %d episodes in %s, saved as each ends", s.writer->episodes(),
                        fs::path(s.writer->path()).filename().c_str());
  }
  ImGui::End();
}

void top_bar(Console::State& s, ImVec2 size) {
  ImGui::SetNextWindowPos(ImVec2(0, 0));
  ImGui::SetNextWindowSize(ImVec2(size.x, 40));
  ImGui::PushStyleColor(ImGuiCol_WindowBg, ImVec4(0.07f, 0.075f, 0.09f, 1.f));
  ImGui::Begin("##top", nullptr, ImGuiWindowFlags_NoDecoration | ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoSavedSettings);
  if (g_bold) ImGui::PushFont(g_bold);
  ImGui::TextUnformatted("diffdagger");
  if (g_bold) ImGui::PopFont();
  ImGui::SameLine(0, 16);
  ImGui::TextDisabled("task");
  ImGui::SameLine();
  ImGui::TextUnformatted(s.o.config.task.c_str());
  ImGui::SameLine(0, 16);
  ImGui::TextDisabled("method");
  ImGui::SameLine();
  ImGui::TextUnformatted(s.o.method.c_str());
  ImGui::SameLine(0, 24);
  // the control-mode pill
  const Control c = s.session->in_episode() ? s.session->actor() : Control::kRobot;
  std::string mode = s.session->done() ? "done" : s.updating() ? "updating" : s.awaiting ? "WAITING FOR THE OPERATOR" : control_label(c);
  if (s.paused && !s.session->done()) mode += " (paused)";
  const ImVec2 ts = ImGui::CalcTextSize(mode.c_str());
  const ImVec2 p = ImGui::GetCursorScreenPos();
  const ImU32 col = s.awaiting ? kViolationRed : s.updating() ? IM_COL32(90, 96, 110, 255) : control_color(c);
  ImGui::GetWindowDrawList()->AddRectFilled(ImVec2(p.x - 8, p.y - 2), ImVec2(p.x + ts.x + 8, p.y + ts.y + 2), col, 10.f);
  ImGui::TextUnformatted(mode.c_str());
  const char* hint = "F1 help";
  ImGui::SameLine(size.x - ImGui::CalcTextSize(hint).x - 16);
  ImGui::TextDisabled("%s", hint);
  ImGui::End();
  ImGui::PopStyleColor();
}

void help_overlay(Console::State& s, ImVec2 size) {
  if (!s.show_help) return;
  ImGui::SetNextWindowPos(ImVec2(size.x * 0.5f, size.y * 0.5f), 0, ImVec2(0.5f, 0.5f));
  ImGui::SetNextWindowBgAlpha(0.96f);
  ImGui::Begin("Keys", &s.show_help, ImGuiWindowFlags_AlwaysAutoResize | ImGuiWindowFlags_NoSavedSettings | ImGuiWindowFlags_NoCollapse);
  // the key column as wide as its widest entry (in the bold font it is drawn in), plus a gap
  const auto keys = console_keys();
  if (g_bold) ImGui::PushFont(g_bold);
  float key_width = 0;
  for (const auto& [k, what] : keys) key_width = std::max(key_width, ImGui::CalcTextSize(k.c_str()).x);
  if (g_bold) ImGui::PopFont();
  const float description_x = ImGui::GetCursorPosX() + key_width + 2 * ImGui::GetStyle().ItemSpacing.x + 8;
  for (const auto& [k, what] : keys) {
    if (g_bold) ImGui::PushFont(g_bold);
    ImGui::TextUnformatted(k.c_str());
    if (g_bold) ImGui::PopFont();
    ImGui::SameLine(description_x);
    ImGui::TextUnformatted(what.c_str());
  }
  ImGui::Separator();
  ImGui::TextDisabled("Queries %s. Every episode is saved to the data set as it ends.",
                      s.o.pause_on_query ? "pause the session until you answer" : "are answered by the scripted expert");
  ImGui::End();
}

void close_dialog(Console::State& s) {
  if (!s.close_dialog) return;
  ImGui::OpenPopup("Quit?");
  if (ImGui::BeginPopupModal("Quit?", nullptr, ImGuiWindowFlags_AlwaysAutoResize)) {
    ImGui::Text("Episode %d is in progress with expert steps in it.", s.session->episode());
    ImGui::TextDisabled("Saving keeps them in the data set as a shortened episode.");
    if (ImGui::Button("Save it and quit (Enter)")) {
      s.quitting = true;
      s.close_dialog = false;
      ImGui::CloseCurrentPopup();
    }
    ImGui::SameLine();
    if (ImGui::Button("Keep working (Esc)")) {
      s.close_dialog = false;
      ImGui::CloseCurrentPopup();
    }
    ImGui::EndPopup();
  }
}

}  // namespace

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
  for (int k : in.pressed) handle_key(s, k);
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
  help_overlay(s, size);
  close_dialog(s);
}

}  // namespace dd::ui
