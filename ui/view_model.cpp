#include "ui/view_model.h"

namespace dd::ui {

void ViewModel::on_event(const SessionEvent& e, bool expert_acted) {
  switch (e.kind) {
    case EventKind::kEpisodeStart:
      timelines_.push_back({e.episode, {}, false, false});
      while (timelines_.size() > kMaxTimelines) timelines_.pop_front();
      path_.clear();
      break;
    case EventKind::kDecision:
      decisions_.push_back({decision_count_++, e.episode, e.score, e.threshold, e.violation, e.run, e.risk_q, e.reason});
      while (decisions_.size() > kMaxDecisions) decisions_.pop_front();
      last_decision_ms_ = e.inference_s * 1e3;
      break;
    case EventKind::kQuery: ++counts_.queries; break;
    case EventKind::kTakeover:
      if (e.control == Control::kOperator) ++counts_.takeovers;
      else if (e.control == Control::kExpertTimeout) ++counts_.timeouts;
      break;
    case EventKind::kEpisodeEnd:
      if (!timelines_.empty()) {
        timelines_.back().ended = true;
        timelines_.back().success = e.success;
      }
      if (e.control == Control::kRobot && !expert_acted) {
        ++counts_.robot_episodes;
        if (e.success) ++counts_.robot_successes;
      }
      break;
    case EventKind::kUpdateFinished: last_report_ = e.report; break;
    default: break;
  }
}

void ViewModel::on_step(int episode, Control actor, const std::optional<Eigen::Vector2d>& position) {
  if (position) path_.emplace_back(*position, actor);
  if (!timelines_.empty() && timelines_.back().episode == episode) timelines_.back().steps.push_back(actor);
}

}  // namespace dd::ui
