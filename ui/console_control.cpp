// The controller: session events, the operator's commands (ui/commands.h) and actions, and the
// worker's jobs, all on the frame thread. The only code that changes the session (the worker computes an update's report; its
// result is applied here, ui/worker.h).
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>

#include "ui/console_state.h"

namespace dd::ui::console {
namespace fs = std::filesystem;

void handle_event(Console::State& s, const SessionEvent& e) {
  (*s.log)(e);
  s.view.on_event(e, s.session->expert_acted());
  switch (e.kind) {
    case EventKind::kEpisodeStart:
      s.answering = Console::State::Answer::kNobody;
      s.awaiting = false;
      s.dragging = false;
      break;
    case EventKind::kQuery:
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
        s.teleop->begin();
        s.answering = Console::State::Answer::kOperator;
        s.takeover_steps = 0;
      } else if (e.control == Control::kExpertTimeout) {
        s.answering = Console::State::Answer::kScripted;
      }
      break;
    case EventKind::kHandBack:
      s.answering = Console::State::Answer::kNobody;
      s.awaiting = false;
      s.dragging = false;
      break;
    case EventKind::kEpisodeEnd:
      s.awaiting = false;
      if (s.takeover_steps >= 0) s.request_shot("takeover");
      s.takeover_steps = -1;
      break;
    case EventKind::kUpdateFinished:
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

// The method's score over a grid of plane points, the agent at rest there and the rest of the episode
// as it is (the obstacle where it is now). The observations are taken here, on the frame thread; the
// worker only scores them.
void start_field(Console::State& s) {
  const std::optional<PlaneScene> plane = s.env->plane();
  if (!plane || s.session->updates() == 0) return;
  const int n = s.field_n;
  const double half = plane->half;
  std::vector<std::pair<int, Vec>> probes;  // grid cell, observation
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i)
      if (auto obs = s.env->observation_at_rest({-half + (i + 0.5) * 2 * half / n, -half + (j + 0.5) * 2 * half / n}))
        probes.emplace_back(j * n + i, std::move(*obs));
  Method& method = *s.method;
  s.worker.start(WorkerJob::kField, [&s, &method, probes = std::move(probes), n](std::atomic<float>& progress) -> Worker::Apply {
    std::vector<float> logs(static_cast<size_t>(n * n), NAN);
    for (size_t k = 0; k < probes.size(); ++k) {
      const auto& [cell, obs] = probes[k];
      const float score = method.decide(obs, 17 + static_cast<uint64_t>(cell)).score;
      logs[static_cast<size_t>(cell)] = std::log(std::max(score, 1e-12f));
      progress = float(k + 1) / float(probes.size());
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
  s.teleop->begin();
  s.awaiting = false;
  s.takeover_steps = 0;
  s.operator_countdown = -1;
  s.session->operator_answers_query();  // the data set labels these steps the operator's
  s.view.on_operator_answer();           // and the console shows and counts them as the operator's
  s.log->note("operator_answers", "episode " + std::to_string(s.session->episode()));
}

void take_over(Console::State& s) {
  if (s.awaiting) {
    answer_as_operator(s);
  } else if (s.session->take_over()) {
    drain(s);
  }
}

void execute(Console::State& s, Command c) {
  if (s.deciding() && binding(c).changes_session) {  // acted on as soon as the decision is in
    s.deferred.push_back(c);
    return;
  }
  const bool idle = !s.busy();
  switch (c) {
    case Command::kTakeOver: if (idle) take_over(s); break;
    case Command::kExpertAnswers:
      if (s.awaiting) {
        s.answering = Console::State::Answer::kScripted;
        s.awaiting = false;
        s.log->note("scripted_expert_answers", "episode " + std::to_string(s.session->episode()));
      }
      break;
    case Command::kHandBack:
      if (idle && s.session->hand_back()) drain(s);
      break;
    case Command::kPause: s.paused = !s.paused; break;
    case Command::kStep: s.paused = true; s.step_once = true; break;
    case Command::kReset:
      if (idle && s.session->in_episode()) {
        s.session->end_episode_now();
        s.log->note("reset", "episode " + std::to_string(s.session->episode()));
        drain(s);
      }
      break;
    case Command::kSave: if (idle) save_policy(s); break;
    case Command::kToggleGrip: s.teleop->toggle_grip(); break;
    case Command::kNextCamera:
      if (s.physics) s.camera = s.camera + 1 >= static_cast<int>(s.cameras.size()) ? -1 : s.camera + 1;
      break;
    case Command::kToggleField:
      s.show_field = !s.show_field;
      if (s.show_field && !s.field_valid) s.field_wanted = true;
      break;
    case Command::kFaster: s.o.speed = std::min(s.o.speed * 2, 16.0); break;
    case Command::kSlower: s.o.speed = std::max(s.o.speed / 2, 0.125); break;
    case Command::kHelp: s.show_help = !s.show_help; break;
    case Command::kScreenshot: s.shots.push_back("screenshot_" + std::to_string(++s.screenshot_count)); break;
    case Command::kConfirm:
      if (s.close_dialog) {
        s.close_dialog = false;
        s.quitting = true;
      }
      break;
    case Command::kBack:
      if (s.close_dialog) s.close_dialog = false;
      else if (s.show_help) s.show_help = false;
      else if (s.session->in_episode() && s.session->expert_acted()) s.close_dialog = true;
      else s.quitting = true;
      break;
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
        std::vector<Command> deferred;
        deferred.swap(s.deferred);
        for (Command c : deferred) execute(s, c);
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
    const std::optional<PlaneScene> plane = s.env->plane();
    s.view.on_step(s.session->episode(), used, plane ? std::optional<Eigen::Vector2d>(plane->agent.center) : std::nullopt);
    if (s.takeover_steps >= 0 && ++s.takeover_steps == 20) s.request_shot("takeover");
    if (s.session->update_pending() || s.awaiting || s.session->done()) break;
  }
}


// What the operator's devices give this step, for the task's teleoperation.
OperatorInput operator_input(const Console::State& s) {
  OperatorInput in;
  in.jog = s.jog;
  in.lift = s.lift;
  in.has_target = s.dragging;
  in.target = s.drag_target;
  if (s.physics && s.camera < 0) {  // the free camera's forward direction on the ground; fixed cameras look along x
    const double az = s.free_cam.azimuth * M_PI / 180;
    in.forward = Eigen::Vector2d(std::cos(az), std::sin(az));
  }
  return in;
}

}  // namespace dd::ui::console
