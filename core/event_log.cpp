#include "core/event_log.h"

#include <nlohmann/json.hpp>

#include "core/config.h"

namespace dd {

EventLog::EventLog(const std::string& path) : path_(path), f_(path, std::ios::app) {
  if (!f_) throw Error(path + ": could not open the event log");
}

void EventLog::write(const std::string& line) {
  f_ << line << '\n';
  f_.flush();
  if (!f_) throw Error(path_ + ": could not append to the event log (disk full?)");
}

void EventLog::operator()(const SessionEvent& e) {
  if (e.kind == EventKind::kUpdateProgress) return;
  nlohmann::json j{{"event", to_string(e.kind)}, {"episode", e.episode}, {"step", e.step}, {"control", to_string(e.control)}};
  if (e.kind == EventKind::kDecision) {
    j["score"] = e.score;
    j["threshold"] = e.threshold;
    j["violation"] = e.violation;
    j["run"] = e.run;
    j["inference_ms"] = e.inference_s * 1e3;
    if (e.risk_q >= 0) j["risk_q"] = e.risk_q;
    if (e.score_rows > 0) j["score_rows"] = e.score_rows;
    if (e.reason == QueryReason::kRisk) j["reason"] = "risk";
  }
  if (e.kind == EventKind::kEpisodeEnd) {
    j["success"] = e.success;
    if (e.gave_up) j["gave_up"] = true;
  }
  if (e.kind == EventKind::kUpdateFinished) {
    j["train_s"] = e.report.train_s;
    j["threshold_s"] = e.report.threshold_s;
    j["threshold"] = e.report.threshold;
    j["pairs"] = e.report.pairs;
    if (e.report.train_reused) j["train_reused"] = true;
    if (e.report.threshold_pairs > 0) {
      j["threshold_pairs"] = e.report.threshold_pairs;
      j["threshold_refined"] = e.report.threshold_refined;
    }
  }
  j["expert_demos"] = e.expert_demos;
  j["interventions"] = e.interventions;
  write(j.dump());
}

void EventLog::note(const std::string& event, const std::string& detail) {
  write(nlohmann::json{{"event", event}, {"detail", detail}}.dump());
}

}  // namespace dd
