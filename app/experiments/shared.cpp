// The experiments' shared pieces: demonstrations, method titles and colours, configs and resume points.
#include "app/experiments.h"
#include "app/experiments/shared.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <tuple>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <optional>
#include <sstream>
#include <numeric>
#include <map>
#include <set>
#include <nlohmann/json.hpp>

#include <fcntl.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include "core/text_file.h"
#include "core/dataset.h"
#include "core/ensemble.h"
#include "core/evaluation.h"
#include "core/event_log.h"
#include "core/progress.h"
#include "core/policy.h"
#include "core/session.h"
#include "core/trainer.h"
#include "envs/registry.h"
#include "ui/plot.h"


namespace dd::app {

void make_dirs(const std::string& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw Error(dir + ": could not create the folder: " + ec.message());
}

std::pair<double, double> mean_std(const std::vector<double>& v) {
  if (v.empty()) return {NAN, NAN};
  double m = 0, s = 0;
  for (double x : v) m += x;
  m /= v.size();
  if (v.size() == 1) return {m, 0.0};
  for (double x : v) s += (x - m) * (x - m);
  return {m, std::sqrt(s / (v.size() - 1))};
}

double mean(const std::vector<double>& v) { return mean_std(v).first; }

double fisher_exact_p(long asked_failed, long asked_succeeded, long quiet_failed, long quiet_succeeded) {
  if (std::min({asked_failed, asked_succeeded, quiet_failed, quiet_succeeded}) < 0) throw Error("fisher_exact_p: a negative count");
  const long asked = asked_failed + asked_succeeded, failed = asked_failed + quiet_failed;
  const long n = asked + quiet_failed + quiet_succeeded;
  auto log_choose = [](long k, long j) { return std::lgamma(k + 1.0) - std::lgamma(j + 1.0) - std::lgamma(k - j + 1.0); };
  // log P(asked_failed = x) with both margins fixed
  auto log_p = [&](long x) { return log_choose(failed, x) + log_choose(n - failed, asked - x) - log_choose(n, asked); };
  const double observed = log_p(asked_failed);
  double p = 0;
  for (long x = std::max(0L, asked - (n - failed)); x <= std::min(asked, failed); ++x)
    if (log_p(x) <= observed + 1e-7) p += std::exp(log_p(x));  // ties within rounding count as no more likely
  return std::min(1.0, p);
}

double mantel_haenszel_p(const std::vector<AskFailTable>& strata) {
  double deviation = 0, variance = 0;
  for (const AskFailTable& t : strata) {
    if (std::min({t.asked_failed, t.asked_succeeded, t.quiet_failed, t.quiet_succeeded}) < 0)
      throw Error("mantel_haenszel_p: a negative count");
    const double asked = t.asked_failed + t.asked_succeeded, quiet = t.quiet_failed + t.quiet_succeeded;
    const double failed = t.asked_failed + t.quiet_failed, succeeded = t.asked_succeeded + t.quiet_succeeded;
    const double n = asked + quiet;
    if (n < 2) continue;
    deviation += t.asked_failed - asked * failed / n;  // observed minus expected with the margins fixed
    variance += asked * quiet * failed * succeeded / (n * n * (n - 1));
  }
  if (!(variance > 0)) return 1.0;
  const double corrected = std::max(0.0, std::abs(deviation) - 0.5);
  return std::erfc(std::sqrt(corrected * corrected / variance / 2));  // P(chi-square_1 > statistic)
}

std::vector<Episode> collect_demos(const std::string& task, const std::string& mode, int n, uint64_t seed) {
  auto env = make_env(task);
  auto expert = make_expert(task, mode);
  std::vector<Episode> out;
  for (int e = 0; static_cast<int>(out.size()) < n && e < 10 * n; ++e) {
    const RecordedEpisode ep = expert_episode(*env, *expert, seed * 1000033ull + 777 + static_cast<uint64_t>(e));
    if (ep.success) out.push_back(ep.all_steps());
  }
  return out;
}


std::string method_title(const std::string& m) {
  for (const MethodInfo& i : method_registry())
    if (i.name == m) return i.title;
  return m;  // a folder's own name (plot_runs: a lone DAgger run)
}

ui::Rgb method_color(const std::string& m) {
  for (const MethodInfo& i : method_registry())
    if (i.name == m) return i.color;
  return {130, 130, 130};
}

bool stored_config_matches(const std::string& path, const ExperimentConfig& config) {
  if (!fs::exists(path)) return false;
  nlohmann::json stored;
  try {
    stored = nlohmann::json::parse(read_text(path));
  } catch (const nlohmann::json::exception& e) {
    throw Error(path + ": not a config written by this program (" + std::string(e.what()) + ")");
  }
  // A key the file lacks was written by an older build, before the key existed: it had the value
  // every preset has, so the preset's own value stands in for it.
  nlohmann::json merged;
  try {
    merged = nlohmann::json::parse(to_json_text(preset(config.preset)));
  } catch (const Error&) {
    merged = nlohmann::json::object();
  }
  merged.merge_patch(stored);
  return merged == nlohmann::json::parse(to_json_text(config));
}

ExperimentConfig resolve_config(const std::string& task, const std::string& config_file) {
  if (!config_file.empty()) {
    ExperimentConfig c = load_experiment_config(config_file);
    if (!task.empty() && c.task != task)
      throw Error(config_file + ": preset '" + c.preset + "' is for task '" + c.task + "', not '" + task + "'");
    return c;
  }
  return preset(task_info(task).preset);
}

int bc_budget_factor(const DaggerConfig& d) {
  return 1 + (d.final_demos - d.initial_demos + d.demos_per_update - 1) / d.demos_per_update;
}

TrainConfig rq1_training(const ExperimentConfig& c) {
  TrainConfig t = c.train;
  if (!t.from_scratch) t.steps *= bc_budget_factor(c.dagger);
  return t;
}

nlohmann::json read_resume_point(const std::string& out, const std::string& marker, const ExperimentConfig& config,
                                 const std::vector<std::string>& required) {
  if (!fs::exists(marker)) return nullptr;
  if (!stored_config_matches(out + "/config.json", config))
    throw Error(out + "/config.json: a stopped run with another config is in this folder (its resume point is " + marker +
                "); remove the folder or choose another --out");
  nlohmann::json point;
  try {
    point = nlohmann::json::parse(read_text(marker));
    for (const std::string& key : required) point.at(key).get<int64_t>();
  } catch (const nlohmann::json::exception& e) {
    throw Error(marker + ": not a resume point (" + std::string(e.what()) + ")");
  }
  return point;
}

}  // namespace dd::app
