// The operator console: one DAgger session (task, method, scripted expert, data set) with its live
// views. The platform layer (a GLFW window, or EGL with no display) calls frame() once per frame
// between ImGui's NewFrame and Render; everything the operator sees and does goes through it, so the
// headless screenshots show exactly what the window shows.
//
// Threads: the session ticks on the frame thread; policy updates and the loss field run on one worker
// thread while the session waits (the window stays responsive). Session events from either thread are
// queued and handled on the frame thread.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "core/task_config.h"
#include "ui/commands.h"

namespace dd::ui {

struct ConsoleOptions {
  ExperimentConfig config;           // task, policy, training, DAgger schedule, query rule
  std::string method = "diff";       // diff | ensemble | thrifty | bc
  std::string expert_mode;  // empty: the config's expert
  std::string out;                   // folder: dataset.hdf5, session.jsonl, checkpoints/
  std::vector<std::string> policies;  // the first update adopts these checkpoints instead of training
                                      // (one; one per member for ensemble, thrifty); config.policy must be theirs
  bool pause_on_query = true;        // false: the scripted expert answers a query at once
  bool scripted_operator = false;    // the scripted expert plays the operator (headless runs)
  int operator_delay = 12;           // scripted operator: frames between a query and its takeover
  double speed = 1.0;                // control steps per second, as a multiple of the task's rate
  bool fixed_step = false;           // one control step per frame (headless), else real time
};

/// What the platform layer saw since the last frame.
struct FrameInput {
  double dt = 1.0 / 60;              // seconds
  std::vector<Command> commands;      // the operator's commands (keys and buttons through ui/commands.h), in order
  Eigen::Vector2d jog{0, 0};         // drive direction from held keys or a stick, each in [-1, 1]
  double lift = 0;                   // arm tasks: raise (+1) or lower (-1) the target
  bool close_requested = false;      // the window's close button
};

class Console {
 public:
  /// Builds the env, expert, method, data set and session; throws dd::Error on bad input
  /// (unknown task or method, an existing data set in `out`). Needs a current GL context.
  explicit Console(const ConsoleOptions& options);
  ~Console();
  Console(const Console&) = delete;
  Console& operator=(const Console&) = delete;

  /// Advances the session and builds this frame's ImGui windows.
  void frame(const FrameInput& input);
  /// Screenshot names due after this frame is rendered ("query", "takeover", "update"; "screenshot"
  /// for the operator's key), cleared by the call.
  std::vector<std::string> take_screenshot_requests();
  /// True once the operator chose to quit (or, headless, when the session is done).
  bool quit() const;
  /// Saves what is in flight (the current episode, the policy) and stops the worker; idempotent.
  void shutdown();

  // What tests and the headless runner look at.
  int episode() const;
  int updates() const;
  int queries() const;
  int operator_takeovers() const;
  bool session_done() const;
  /// True while the worker runs a policy update or computes the loss field.
  bool busy() const;
  const std::string& log_path() const;

  struct State;

 private:
  std::unique_ptr<State> s_;
};

/// Key bindings as (keys, what they do), for the help overlay and the README: the rows of
/// ui/commands.h's table.
std::vector<std::pair<std::string, std::string>> console_keys();

}  // namespace dd::ui
