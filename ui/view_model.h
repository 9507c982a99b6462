// What the console's panels show, built from the session's events and steps: the loss trace, one
// timeline row per episode, the agent's path in a plane, and the counters. The controller feeds it
// on the frame thread; panels only read it. No GL or GUI here, so it is tested on its own.
#pragma once

#include <deque>
#include <optional>
#include <utility>
#include <vector>

#include "core/session.h"

namespace dd::ui {

/// One robot decision as the loss plot draws it.
struct DecisionPoint {
  int index = 0;  // 0-based over the session
  int episode = 0;
  float score = 0, threshold = 0;
  bool violation = false;
  int run = 0;        // violations in a row
  float risk_q = -1;  // Thrifty: the critic's min Q (-1: not computed)
  QueryReason reason = QueryReason::kNone;
};

/// Who acted at each step of one episode.
struct Timeline {
  int episode = 0;
  std::vector<Control> steps;
  bool ended = false, success = false;
};

struct ConsoleCounts {
  int queries = 0, timeouts = 0;
  int takeovers = 0;  // by the operator: taking over, or answering a query
  int robot_episodes = 0, robot_successes = 0;  // episodes the robot ran alone, and how many succeeded
};

class ViewModel {
 public:
  static constexpr size_t kMaxDecisions = 400;  // the plot's memory
  static constexpr size_t kMaxTimelines = 64;

  /// One session event, in the order the session emitted it. `expert_acted`: whether the expert or the
  /// operator acted in the episode (read at its end: an episode the robot ran alone counts as such).
  void on_event(const SessionEvent& e, bool expert_acted);
  /// The operator answers a query: the console counts it as the operator's takeover.
  void on_operator_answer() { ++counts_.takeovers; }
  /// One control step of `episode`: who acted, and where the agent is in the task's plane afterwards
  /// (tasks drawn as a plane; none for the others).
  void on_step(int episode, Control actor, const std::optional<Eigen::Vector2d>& position);

  const std::deque<DecisionPoint>& decisions() const { return decisions_; }
  const std::deque<Timeline>& timelines() const { return timelines_; }
  /// This episode's path in the plane, each point with who acted to reach it.
  const std::vector<std::pair<Eigen::Vector2d, Control>>& path() const { return path_; }
  const ConsoleCounts& counts() const { return counts_; }
  const UpdateReport& last_report() const { return last_report_; }
  double last_decision_ms() const { return last_decision_ms_; }
  /// Who acted last in this episode's path (the robot before the first step).
  Control last_actor() const { return path_.empty() ? Control::kRobot : path_.back().second; }

 private:
  std::deque<DecisionPoint> decisions_;
  int decision_count_ = 0;
  std::deque<Timeline> timelines_;
  std::vector<std::pair<Eigen::Vector2d, Control>> path_;
  ConsoleCounts counts_;
  UpdateReport last_report_;
  double last_decision_ms_ = 0;
};

}  // namespace dd::ui
