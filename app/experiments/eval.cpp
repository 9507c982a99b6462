// The evaluation (eval): its cells (RQ1, RQ2 and RQ3 of one method and seed), run in-process or in child
// processes and resumable; eval_report.cpp writes the report from them.
#include "app/experiments.h"
#include "app/experiments/eval_report.h"
#include "app/experiments/shared.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <tuple>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
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

#include "core/runtime.h"
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


namespace dd::app {

void EvalOptions::apply_quick(ExperimentConfig& c) {
  quick = true;
  episodes = 8;
  c.method.members = 3;  // a smoke test: ensembles of 3, not the method's 5
  c.train.steps = 50;
  c.train.warmup_steps = 10;
  c.dagger.initial_demos = 3;
  c.dagger.final_demos = 7;
  c.dagger.demos_per_update = 2;
  c.method.calibration_pairs = 100;
  c.method.loss_samples = 128;
  c.method.critic.steps = 100;
  c.rq1_demos = 2;
}

namespace {


}  // namespace

namespace {

std::vector<std::string>& command_line_store() {
  static std::vector<std::string> args;
  return args;
}

// The arguments of this process for a child that runs one cell: the same command with one thread
// and no --jobs (the child gets --cell instead).
std::vector<std::string> child_arguments(const std::string& cell) {
  const std::vector<std::string>& args = command_line_store();
  if (args.empty()) throw Error("eval --jobs: the command line was not recorded (set_command_line)");
  std::vector<std::string> out{args[0], "--threads", "1"};
  for (size_t i = 1; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "--threads" || a == "--jobs" || a == "--cell") {
      ++i;  // and its value
      continue;
    }
    if (a.rfind("--threads=", 0) == 0 || a.rfind("--jobs=", 0) == 0 || a.rfind("--cell=", 0) == 0) continue;
    out.push_back(a);
  }
  out.push_back("--cell");
  out.push_back(cell);
  return out;
}

// Runs each cell in a child process (this executable, `--cell ID`, one thread), `jobs` at a time,
// its output into log_dir/METHOD_seedS_rqN.log. Prints a line as each starts and ends. Throws after
// the last one if any failed, naming their logs; the cells that finished are kept.
void run_cells_in_processes(const std::vector<EvalCell>& cells, int jobs, const std::string& log_dir) {
  if (cells.empty()) return;
  make_dirs(log_dir);
  fmt::print(stderr, "[eval] {} cells, {} at a time, one thread each; their output is in {}\n", cells.size(), jobs, log_dir);
  struct Running {
    EvalCell cell;
    std::string log;
    std::chrono::steady_clock::time_point start;
  };
  std::map<pid_t, Running> running;
  std::vector<std::string> failed;
  size_t next = 0, done = 0;
  auto start = [&](const EvalCell& cell) {
    const std::string log = log_dir + "/" + cell.stem() + ".log";
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0) throw Error(log + ": cannot open for writing: " + std::strerror(errno));
    std::vector<std::string> args = child_arguments(cell.id());
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    const pid_t parent = ::getpid();
    const pid_t pid = ::fork();
    if (pid < 0) {
      ::close(fd);
      throw Error(std::string("eval --jobs: fork failed: ") + std::strerror(errno));
    }
    if (pid == 0) {  // the child: only async-signal-safe calls until exec
      ::prctl(PR_SET_PDEATHSIG, SIGTERM);  // a stopped evaluation stops its cells too
      if (::getppid() != parent) ::_exit(126);
      ::dup2(fd, STDOUT_FILENO);
      ::dup2(fd, STDERR_FILENO);
      ::execv("/proc/self/exe", argv.data());
      ::_exit(127);
    }
    ::close(fd);
    running[pid] = Running{cell, log, std::chrono::steady_clock::now()};
    fmt::print(stderr, "[eval] started {} (pid {})\n", cell.id(), pid);
  };
  while (next < cells.size() || !running.empty()) {
    while (static_cast<int>(running.size()) < jobs && next < cells.size()) start(cells[next++]);
    int status = 0;
    const pid_t pid = ::waitpid(-1, &status, 0);
    if (pid < 0) {
      if (errno == EINTR) continue;
      throw Error(std::string("eval --jobs: waitpid failed: ") + std::strerror(errno));
    }
    const auto it = running.find(pid);
    if (it == running.end()) continue;
    ++done;
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - it->second.start).count();
    const bool ok = WIFEXITED(status) && WEXITSTATUS(status) == 0;
    const std::string how = ok                    ? "finished"
                            : WIFSIGNALED(status) ? fmt::format("killed by signal {}", WTERMSIG(status))
                                                  : fmt::format("failed with exit code {}", WEXITSTATUS(status));
    fmt::print(stderr, "[eval] {}/{} cells: {} {} in {}\n", done, cells.size(), it->second.cell.id(), how, format_duration(s));
    if (!ok) failed.push_back(it->second.cell.id() + " (" + it->second.log + ")");
    running.erase(it);
  }
  if (!failed.empty()) {
    std::string list;
    for (const std::string& f : failed) list += (list.empty() ? "" : ", ") + f;
    throw Error(fmt::format("eval: {} of {} cells failed: {}; the others are kept in cells/, and running the same command again "
                            "retries the failed ones",
                            failed.size(), cells.size(), list));
  }
}

}  // namespace

std::vector<std::string> rq1_policies(const ExperimentConfig& c, int members, const std::vector<Episode>& demos, const std::string& dir,
                                      const std::string& label) {
  make_dirs(dir);
  // The ensemble's members train on what Ensemble-DAgger's own update would give them; member 0 on
  // all the demonstrations, from the seed Diff-DAgger's policy starts from.
  PolicyEnsemble ensemble(c.policy, c.method.members, c.dagger.seed);
  const std::vector<std::vector<Episode>> data = ensemble.member_data(demos);
  const TrainConfig train = rq1_training(c);
  std::vector<std::string> paths;
  for (int i = 0; i < members; ++i) paths.push_back(dir + "/member_" + std::to_string(i) + ".pt");
  // One lock file per member: cells running side by side (eval --jobs) take the members nobody is
  // training, then wait for the others. A member is written when its training ends, so a stopped
  // cell loses at most the member in progress.
  auto train_member = [&](int i) {
    ProgressBar bar(fmt::format("{} member {} of {} train", label, i + 1, c.method.members), "loss");
    ensemble.train_member(i, data[static_cast<size_t>(i)], train, bar.fn());
    ensemble.member(i).save(paths[static_cast<size_t>(i)]);
  };
  auto with_lock = [&](int i, bool wait) {
    const std::string lock_path = paths[static_cast<size_t>(i)] + ".lock";
    const int fd = ::open(lock_path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0) throw Error(lock_path + ": could not open the lock file: " + std::strerror(errno));
    if (::flock(fd, LOCK_EX | (wait ? 0 : LOCK_NB)) != 0) {
      ::close(fd);
      return false;
    }
    try {
      if (!fs::exists(paths[static_cast<size_t>(i)])) train_member(i);  // a neighbour may have finished it meanwhile
    } catch (...) {
      ::close(fd);
      throw;
    }
    ::close(fd);  // releases the lock
    return true;
  };
  std::vector<int> waiting;
  for (int i = 0; i < members; ++i)
    if (!fs::exists(paths[static_cast<size_t>(i)]) && !with_lock(i, false)) waiting.push_back(i);
  for (int i : waiting) {
    fmt::print(stderr, "{}: member {} is being trained by another cell; waiting for it\n", label, i + 1);
    with_lock(i, true);
  }
  return paths;
}

void set_command_line(int argc, char** argv) {
  command_line_store().assign(argv, argv + argc);
}

std::string EvalCell::id() const { return fmt::format("{}:{}:{}", method, seed, rq1 ? "rq1" : "rq2"); }
std::string EvalCell::stem() const { return fmt::format("{}_seed{}_{}", method, seed, rq1 ? "rq1" : "rq2"); }

std::vector<EvalCell> eval_cells(const std::vector<std::string>& methods, int seeds) {
  // rough cost: ensembles train 5 members; a DAgger run trains about as much as BC on N_f
  auto cost = [](const EvalCell& c) {
    const MethodInfo& m = method_info(c.method);
    const double members = m.ensemble ? 5 : 1;
    return members * (c.rq1 ? 1.0 : 2.0) + (m.learns_risk ? 0.5 : 0.0);
  };
  std::vector<EvalCell> cells;
  for (int s = 0; s < seeds; ++s)
    for (const std::string& m : methods) {
      if (method_info(m).gated) cells.push_back({m, s, true});
      cells.push_back({m, s, false});
    }
  std::stable_sort(cells.begin(), cells.end(), [&](const EvalCell& a, const EvalCell& b) { return cost(a) > cost(b); });
  return cells;
}

EvalCell parse_eval_cell(const std::string& id, const std::vector<std::string>& methods, int seeds) {
  const size_t a = id.find(':'), b = id.rfind(':');
  const std::string bad = "--cell '" + id + "': ";
  if (a == std::string::npos || a == b) throw Error(bad + "expected METHOD:SEED:rq1 or METHOD:SEED:rq2");
  EvalCell c;
  c.method = id.substr(0, a);
  if (std::find(methods.begin(), methods.end(), c.method) == methods.end()) throw Error(bad + "method '" + c.method + "' is not in --methods");
  const std::string seed = id.substr(a + 1, b - a - 1), kind = id.substr(b + 1);
  if (seed.empty() || seed.find_first_not_of("0123456789") != std::string::npos || seed.size() > 3 || std::stoi(seed) >= seeds)
    throw Error(bad + "seed '" + seed + "' is not one of 0.." + std::to_string(seeds - 1));
  c.seed = std::stoi(seed);
  if (kind != "rq1" && kind != "rq2") throw Error(bad + "'" + kind + "' is not rq1 or rq2");
  c.rq1 = kind == "rq1";
  if (c.rq1 && !method_info(c.method).gated) throw Error(bad + method_info(c.method).title + " has no RQ1 cell (it never asks)");
  return c;
}

namespace {

// RQ1's rollouts, one JSON line each, so that a stopped cell keeps the ones that ended.
void append_rollout(const std::string& path, const RolloutResult& r) {
  std::ofstream f(path, std::ios::app);
  f << rollout_to_json(r) << "\n";
  f.flush();
  if (!f) throw Error(path + ": could not append a rollout (disk full?)");
}

// The rollouts a stopped cell wrote; a last line cut short by the stop is dropped (that episode runs again).
std::vector<RolloutResult> read_rollouts(const std::string& path) {
  std::vector<RolloutResult> out;
  if (!fs::exists(path)) return out;
  std::istringstream lines(read_text(path));
  std::string line;
  int n = 0;
  while (std::getline(lines, line)) {
    ++n;
    if (lines.eof() && !line.empty()) break;  // no newline: cut short
    try {
      out.push_back(rollout_from_json(line));
    } catch (const Error& e) {
      throw Error(path + ": line " + std::to_string(n) + " is " + e.what() + "; remove the file to run its rollouts again");
    }
  }
  return out;
}

}  // namespace

void run_eval(const ExperimentConfig& config, const EvalOptions& o) {
  config.validate();
  if (!o.report_only) make_dirs(o.out + "/cells");
  // Every finished cell (RQ1, or RQ2 and RQ3, of one method and seed) is a file in out/cells; a
  // stopped evaluation rerun with the same config skips them, losing at most the cell in progress.
  const std::string config_text = to_json_text(config) + "\n";
  if (!o.report_only && fs::exists(o.out + "/config.json") && !stored_config_matches(o.out + "/config.json", config) &&
      !fs::is_empty(o.out + "/cells"))
    throw Error(o.out + "/config.json: finished cells of another config are in " + o.out +
                "/cells; remove the folder or choose another --out");
  if (o.report_only) {
    // eval --report reads what the evaluation in this folder has finished; its config must be this one
    if (!fs::exists(o.out + "/config.json")) throw Error(o.out + "/config.json: missing; --report needs the folder of an evaluation");
    if (!stored_config_matches(o.out + "/config.json", config))
      throw Error(o.out + "/config.json: --report writes the report of the evaluation whose config this file holds, and it holds another "
                  "(give the same --task, --config and --quick as the evaluation)");
  } else if (o.cell.empty() || !fs::exists(o.out + "/config.json")) {
    // a --cell run on its own in a new folder prepares it, as a whole evaluation would
    write_text(o.out + "/config.json", config_text);
  } else if (!stored_config_matches(o.out + "/config.json", config)) {
    // a cell's process (eval --jobs) runs in the folder its parent prepared, and only reads it
    throw Error(o.out + "/config.json: --cell runs a cell of the evaluation whose config this file holds, and it holds another");
  }
  // Ensemble-DAgger and Thrifty-DAgger train the same ensemble on the same data until their queries
  // first differ (always at the first update): the second of them loads what the first trained.
  struct CacheScope {
    explicit CacheScope(const std::string& dir) { set_ensemble_train_cache(dir); }
    ~CacheScope() { set_ensemble_train_cache(""); }
  } cache_scope(o.train_cache && !o.report_only ? o.out + "/runs/ensemble_cache" : "");
  std::map<std::string, EvalRow> rows;
  auto env = make_env(config.task);
  const DaggerConfig& d = config.dagger;
  const RolloutSpec spec = RolloutSpec::of(d);
  const auto t_start = std::chrono::steady_clock::now();
  int skipped = 0;  // cells read from out/cells

  // A cell's file, if it was finished with this many rollouts per measurement (else an Error).
  // `fresh`: cells made by this run (read back, not counted as skipped).
  auto finished = [&](const std::string& path, const std::set<std::string>& fresh) -> std::optional<nlohmann::json> {
    if (!fs::exists(path)) return std::nullopt;
    nlohmann::json j;
    try {
      j = nlohmann::json::parse(read_text(path));
    } catch (const nlohmann::json::exception& e) {
      throw Error(path + ": not a finished cell (" + std::string(e.what()) + "); remove it to run the cell again");
    }
    if (j.value("episodes", -1) != o.episodes)
      throw Error(path + ": finished with " + std::to_string(j.value("episodes", -1)) + " rollouts per measurement (field 'episodes'), this run asks for " +
                  std::to_string(o.episodes));
    if (!fresh.count(path)) {
      fmt::print(stderr, "{}: finished, skipped\n", path);
      ++skipped;
    }
    return j;
  };
  auto cell_file = [&](const std::string& name, int s, bool rq1) { return o.out + "/cells/" + EvalCell{name, s, rq1}.stem() + ".json"; };
  // An RQ1 cell's rollouts, one JSON line each, beside the cell
  auto cell_rollouts_file = [&](const std::string& name, int s) { return o.out + "/cells/" + EvalCell{name, s, true}.stem() + "_rollouts.jsonl"; };
  std::set<std::string> ran_here;  // cells finished by this run (in this process or its children)
  auto save_cell = [&](const std::string& path, nlohmann::json j) {
    j["episodes"] = o.episodes;
    // The writing process's libtorch threads: a cell's seconds are only comparable at the same count
    // (a cell continued from out/partial may have started under another).
    j["threads"] = num_threads();
    write_text(path, j.dump(2) + "\n");
    ran_here.insert(path);
  };
  auto has_method = [&](const std::string& m) { return std::find(o.methods.begin(), o.methods.end(), m) != o.methods.end(); };
  // Ensemble-DAgger's rule is Thrifty-DAgger's novelty half: the seed's one RQ1 ensemble, the same
  // threshold (EnsembleMethod::set_threshold, same seed, same pairs), the same acting member and
  // rollout seeds. So Thrifty's RQ1 cell also gives Ensemble-DAgger's, and a seed that needs both
  // runs Thrifty's alone: one pass of five-member sampling, not two.
  auto thrifty_gives_ensemble = [&](int s) {
    return has_method("ensemble") && has_method("thrifty") && !fs::exists(cell_file("ensemble", s, true)) &&
           !fs::exists(cell_file("thrifty", s, true));
  };

  // One seed's config and rollout seeds.
  auto seed_config = [&](int s) {
    ExperimentConfig c = config;
    c.dagger.seed = config.dagger.seed + static_cast<uint64_t>(s);
    return c;
  };
  auto eval_seed_of = [](int s) { return 900000 + 1000 * static_cast<uint64_t>(s); };

  // RQ1: a policy trained on N_D demonstrations, rolled out without intervention.
  auto run_rq1_cell = [&](const std::string& name, int s) {
    const ExperimentConfig c = seed_config(s);
    const uint64_t eval_seed = eval_seed_of(s);
    auto m = make_method(name, c.policy, c.method, c.dagger.seed);
    // What a stopped cell keeps (out/partial/STEM, removed when the cell is written): the method as
    // the rollouts see it (policies, thresholds, Thrifty's critic), saved once it is ready, and each
    // rollout as it ends. Rollouts are independent (episode e runs from seed eval_seed + e with the
    // method unchanged), so continuing gives the very numbers an unstopped cell would.
    const std::string partial = o.out + "/partial/" + EvalCell{name, s, true}.stem();
    const std::string state_dir = partial + "/method", rollouts_file = partial + "/rollouts.jsonl";
    // What preparing the method cost and set, kept in prepared.json so a continued cell still reports it
    nlohmann::json prepared{{"risk_data_s", 0.0}};
    if (fs::exists(state_dir + "/method.json")) {
      m->load_state(state_dir);
      prepared = nlohmann::json::parse(read_text(partial + "/prepared.json"));
      fmt::print(stderr, "[seed {}] RQ1 {:8} continues from {}\n", s, name, partial);
    } else {
      const auto demos = collect_demos(c.task, c.expert, c.rq1_demos, c.dagger.seed);
      // The methods' RQ1 policies are one ensemble per seed, trained once (Diff-DAgger's is member 0).
      const auto policies = rq1_policies(c, method_info(name).ensemble ? c.method.members : 1, demos,
                                         o.out + "/rq1_policies/seed" + std::to_string(s), fmt::format("[seed {}] RQ1", s));
      const auto t = std::chrono::steady_clock::now();
      // Diff's compared rules have thresholds of their own; Thrifty's halves share its threshold and gamma.
      const size_t thresholds = 1 + (method_info(name).learns_risk ? 0 : m->compare_rules().size());
      fmt::print(stderr, "[seed {}] RQ1 {:8} setting {} threshold{} over the training pairs...\n", s, name, thresholds,
                 thresholds > 1 ? "s" : "");
      UpdateReport adopted;
      {
        ProgressBar bar(fmt::format("[seed {}] RQ1 {:8} scoring training pairs", s, name), "loss");
        adopted = m->adopt(policies, demos, {}, bar.fn());
      }
      const double thresholds_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
      fmt::print(stderr, "[seed {}] RQ1 {:8} thresholds set in {:.0f} s\n", s, name, thresholds_s);
      // The rule's own threshold pass, apart from the compared rules' (thresholds_s holds them all);
      // Diff-DAgger's screened pass also says how many pairs it scored with every loss sample.
      prepared["thresholds_s"] = thresholds_s;
      prepared["threshold_s"] = adopted.threshold_s;
      if (adopted.threshold_pairs > 0) {
        prepared["threshold_pairs"] = adopted.threshold_pairs;
        prepared["threshold_refined"] = adopted.threshold_refined;
        fmt::print(stderr, "[seed {}] RQ1 {:8} its own threshold: {:.0f} s, {} of {} pairs scored with every loss sample\n", s,
                   name, adopted.threshold_s, adopted.threshold_refined, adopted.threshold_pairs);
      }
      if (method_info(name).learns_risk) {
        // The critic learns from robot rollouts too: roll out, then refit the critic alone (the
        // policies keep the budget every method gets). Those rollouts are Thrifty's extra cost.
        std::vector<RecordedEpisode> robot;
        const auto t = std::chrono::steady_clock::now();
        evaluate_rollouts(*env, *m, std::max(5, o.episodes / 5), spec, eval_seed + 500, {}, &robot);
        double risk_data_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
        risk_data_s += m->refit_risk(demos, robot);
        prepared["risk_data_s"] = risk_data_s;
      }
      m->save_state(state_dir);
      write_text(partial + "/prepared.json", prepared.dump() + "\n");
      fs::remove(rollouts_file);  // rollouts of a method that was not saved are not these rollouts
    }
    std::vector<RolloutResult> results = read_rollouts(rollouts_file);
    {
      ProgressBar bar(fmt::format("[seed {}] RQ1 {:8} rollouts", s, name), "success");
      bar.resume_from(static_cast<int>(results.size()));
      evaluate_rollouts_each(*env, *m, static_cast<int>(results.size()), o.episodes, spec, eval_seed, [&](int e, const RolloutResult& r) {
        results.push_back(r);
        append_rollout(rollouts_file, r);
        bar.update(e + 1, o.episodes, success_rate(results));
      });
    }
    auto prediction_json = [](const FailurePrediction& p) {
      return nlohmann::json{{"tpr", p.tpr}, {"tnr", p.tnr}, {"f1", p.f1}, {"acc", p.accuracy},
                            {"tp", p.tp},   {"fp", p.fp},   {"tn", p.tn}, {"fn", p.fn}};
    };
    nlohmann::json j = prediction_json(failure_prediction(results));
    j["success"] = success_rate(results);
    for (const auto& [key, value] : prepared.items()) j[key] = value;  // risk_data_s, threshold_s, ...
    if (std::isfinite(m->threshold())) j["threshold"] = m->threshold();  // the rule's, as the rollouts saw it
    if (std::isfinite(m->risk_threshold())) j["risk_threshold"] = m->risk_threshold();  // Thrifty's gamma
    // method.compare_scores: the other rules' verdicts on these very rollouts
    const std::vector<std::string> rules = m->compare_rules();
    for (size_t i = 0; i < rules.size(); ++i) j["compare"][rules[i]] = prediction_json(failure_prediction(results, i));
    if (!rules.empty()) j["compare_rules"] = rules;  // their order in each rollout's compare_queried
    // Behind the counts, one line a rollout (success, outcome, steps, whether and at which step the
    // rule would have asked, the compared rules' verdicts), kept beside the cell: written before it,
    // so a finished cell always has them
    std::string lines;
    for (const RolloutResult& r : results) lines += rollout_to_json(r) + "\n";
    write_text(cell_rollouts_file(name, s), lines);
    save_cell(cell_file(name, s, true), j);
    fs::remove_all(partial);
    const auto novelty = std::find(rules.begin(), rules.end(), "novelty");
    const size_t n = static_cast<size_t>(novelty - rules.begin());
    const bool halves_recorded = std::all_of(results.begin(), results.end(), [&](const RolloutResult& r) {
      return r.compare_queried.size() == rules.size() && r.compare_first_query_step.size() == rules.size();
    });
    if (name == "thrifty" && has_method("ensemble") && novelty != rules.end() && halves_recorded &&
        !fs::exists(cell_file("ensemble", s, true))) {
      const std::vector<RolloutResult> ensemble = judged_by(results, n);
      std::string ensemble_lines;
      for (const RolloutResult& r : ensemble) ensemble_lines += rollout_to_json(r) + "\n";
      nlohmann::json e = prediction_json(failure_prediction(ensemble));
      e["success"] = success_rate(ensemble);
      e["risk_data_s"] = 0.0;
      if (j.contains("threshold")) e["threshold"] = j["threshold"];
      e["from"] = EvalCell{name, s, true}.id();  // its rollouts, judged by the novelty half alone
      write_text(cell_rollouts_file("ensemble", s), ensemble_lines);
      save_cell(cell_file("ensemble", s, true), e);
      fmt::print(stderr, "[seed {}] RQ1 ensemble written from {}'s novelty half\n", s, EvalCell{name, s, true}.id());
    }
  };
  // RQ2 and RQ3: interactive learning to N_f, then rollouts of the final policy.
  auto run_rq2_cell = [&](const std::string& name, int s) {
    const ExperimentConfig c = seed_config(s);
    DaggerRunOptions ro;
    ro.method = name;
    ro.out = o.out + "/runs/" + name + "_seed" + std::to_string(s);
    ro.quiet = true;
    ro.label = fmt::format("[seed {}] RQ2 {:8}", s, name);
    // a cell stopped mid-run continues from its last update's resume point; anything else starts afresh
    if (!fs::exists(ro.out + "/resume/latest.json")) fs::remove_all(ro.out);
    std::unique_ptr<Method> trained;
    fmt::print(stderr, "[seed {}] RQ2 {:8} interactive learning to {} demonstrations...\n", s, name, d.final_demos);
    const DaggerRunResult run = run_dagger(c, ro, &trained);
    std::vector<RolloutResult> results;
    {
      ProgressBar bar(fmt::format("[seed {}] RQ2 {:8} rollouts", s, name), "success");
      results = evaluate_rollouts(*env, *trained, o.episodes, spec, eval_seed_of(s) + 50000, bar.fn());
    }
    auto last_or_zero = [](const std::vector<double>& v) { return v.empty() ? 0.0 : v.back(); };
    const nlohmann::json j{{"success", success_rate(results)},
                           {"train_s", mean(run.iteration_train_s)},
                           {"threshold_s", mean(run.iteration_threshold_s)},
                           {"inference_s", run.iteration_inference_s.empty() ? 0.0 : mean(run.iteration_inference_s)},
                           {"last_train_s", last_or_zero(run.iteration_train_s)},
                           {"last_threshold_s", last_or_zero(run.iteration_threshold_s)},
                           {"last_inference_s", last_or_zero(run.iteration_inference_s)},
                           {"interventions", run.interventions},
                           {"queries", run.queries},
                           {"timeouts", run.timeouts},
                           {"dagger_episodes", run.episodes}};
    save_cell(cell_file(name, s, false), j);
    fmt::print(stderr, "[seed {}] {:8} success {:.2f}; {} interventions ({} queries, {} time-outs) in {} episodes\n", s, name,
               j["success"].get<double>(), run.interventions, run.queries, run.timeouts, run.episodes);
  };

  // A child process of `--jobs`: one cell, then done.
  if (!o.cell.empty()) {
    const EvalCell cell = parse_eval_cell(o.cell, o.methods, o.seeds);
    if (cell.rq1)
      run_rq1_cell(cell.method, cell.seed);
    else
      run_rq2_cell(cell.method, cell.seed);
    return;
  }

  // --only-rq1: the query rules' RQ1 cells alone (no DAgger runs), then their numbers; no report.
  if (o.only_rq1) {
    std::vector<EvalCell> todo;
    for (const EvalCell& cell : eval_cells(o.methods, o.seeds))
      if (cell.rq1 && !fs::exists(cell_file(cell.method, cell.seed, true)) && !(cell.method == "ensemble" && thrifty_gives_ensemble(cell.seed)))
        todo.push_back(cell);
    if (o.jobs > 1) {
      run_cells_in_processes(todo, o.jobs, o.out + "/logs");
    } else {
      for (const EvalCell& cell : todo) run_rq1_cell(cell.method, cell.seed);
    }
    for (int s = 0; s < o.seeds; ++s)  // an Ensemble-DAgger cell Thrifty-DAgger's did not give (halves not recorded)
      if (has_method("ensemble") && !fs::exists(cell_file("ensemble", s, true))) run_rq1_cell("ensemble", s);
    for (int s = 0; s < o.seeds; ++s)
      for (const std::string& name : o.methods) {
        if (!method_info(name).gated) continue;
        const nlohmann::json j = nlohmann::json::parse(read_text(cell_file(name, s, true)));
        fmt::print("[seed {}] RQ1 {:8} TP {} FP {} TN {} FN {} (policy success {:.2f})\n", s, name, j.at("tp").get<int>(),
                   j.at("fp").get<int>(), j.at("tn").get<int>(), j.at("fn").get<int>(), j.at("success").get<double>());
        if (j.contains("compare"))
          for (const auto& [rule, p] : j["compare"].items())
            fmt::print("[seed {}] RQ1 {:8}   by {:13} TP {} FP {} TN {} FN {}\n", s, name, rule, p.at("tp").get<int>(),
                       p.at("fp").get<int>(), p.at("tn").get<int>(), p.at("fn").get<int>());
      }
    fmt::print("RQ1 cells in {}/cells; run without --only-rq1 for RQ2, RQ3 and the report\n", o.out);
    return;
  }

  // --jobs N: the unfinished cells, the longest first, N at a time, each in a process of its own.
  if (o.jobs > 1 && !o.report_only) {
    std::vector<EvalCell> todo;
    for (const EvalCell& cell : eval_cells(o.methods, o.seeds)) {
      const std::string file = cell_file(cell.method, cell.seed, cell.rq1);
      if (fs::exists(file)) continue;
      if (cell.rq1 && cell.method == "thrifty" && thrifty_gives_ensemble(cell.seed)) ran_here.insert(cell_file("ensemble", cell.seed, true));
      if (!(cell.rq1 && cell.method == "ensemble" && thrifty_gives_ensemble(cell.seed))) todo.push_back(cell);
      ran_here.insert(file);
    }
    run_cells_in_processes(todo, o.jobs, o.out + "/logs");
  }

  // A cell's numbers: read back when finished, else run here; with --report, nothing runs and the
  // unfinished cell is listed.
  std::vector<std::string> missing;
  auto cell_numbers = [&](const EvalCell& cell, const std::function<void()>& run) -> std::optional<nlohmann::json> {
    const std::string file = cell_file(cell.method, cell.seed, cell.rq1);
    if (o.report_only) {
      auto j = finished(file, {file});
      if (!j) missing.push_back(cell.id());
      return j;
    }
    auto j = finished(file, ran_here);
    if (!j) {
      run();
      j = finished(file, {file});
    }
    return j;
  };
  for (int s = 0; s < o.seeds; ++s) {
    for (const std::string& name : o.methods) {
      EvalRow& row = rows[name];
      if (method_info(name).gated)
        if (const auto j = cell_numbers({name, s, true}, [&] {
              if (name == "ensemble" && thrifty_gives_ensemble(s)) run_rq1_cell("thrifty", s);
              if (!fs::exists(cell_file(name, s, true))) run_rq1_cell(name, s);  // not given (halves not recorded)
            })) {
          row.add_rq1(*j, (*j)["success"].get<double>(), s);
          // the rollouts behind the counts, for the report's tables of how they ended; a file that
          // cannot be read or is not this cell's costs those tables, not the report
          const std::string file = cell_rollouts_file(name, s);
          try {
            if (fs::exists(file) && !row.add_rq1_rollouts(*j, read_rollouts(file), s))
              fmt::print(stderr, "warning: {}: its counts are not those of {}; left out of the report's tables by outcome\n", file,
                         cell_file(name, s, true));
          } catch (const Error& e) {
            fmt::print(stderr, "warning: {}; left out of the report's tables by outcome\n", e.what());
          }
          if (method_info(name).learns_risk) row.risk_data.push_back((*j)["risk_data_s"].get<double>());
        }
      if (const auto j = cell_numbers({name, s, false}, [&] { run_rq2_cell(name, s); })) row.add_rq2(*j, s);
    }
  }

  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  write_eval_report(config, o, rows, seconds, skipped, missing);
}

}  // namespace dd::app
