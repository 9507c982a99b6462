// Interactive-learning runs (run_dagger), BC training runs (run_train) and their learning curves.
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

namespace {

// "success 12, held 3, not grasped 1": how the rollouts ended, most frequent first.
std::string outcome_counts(const std::vector<RolloutResult>& results) {
  std::map<std::string, int> n;
  for (const auto& r : results) ++n[r.outcome];
  std::vector<std::pair<int, std::string>> sorted;
  for (const auto& [k, v] : n) sorted.emplace_back(-v, k);
  std::sort(sorted.begin(), sorted.end());
  std::string out;
  for (const auto& [v, k] : sorted) out += fmt::format("{}{} {}", out.empty() ? "" : "; ", k, -v);
  return out;
}

}  // namespace

DaggerRunResult run_dagger(const ExperimentConfig& config, const DaggerRunOptions& o, std::unique_ptr<Method>* method_out) {
  config.validate();
  if (o.out.empty()) throw Error("dagger: an output folder is required (--out)");
  make_dirs(o.out + "/checkpoints");
  DaggerRunResult result;
  result.dataset = o.out + "/dataset.hdf5";
  const std::string config_text = to_json_text(config) + "\n", resume_root = o.out + "/resume", log_path = o.out + "/queries.jsonl";
  // A resume point: out/resume/latest.json names the folder of the latest complete one.
  const nlohmann::json resume = read_resume_point(o.out, resume_root + "/latest.json", config, {"update", "log_bytes"});
  const std::string prefix = o.label.empty() ? "" : o.label + " ";  // of the lines per update and on resuming
  if (resume.is_null() && fs::exists(result.dataset)) {
    throw Error(result.dataset + ": already exists; a run never mixes its data into an earlier run's (choose another --out)");
  }
  const std::string resume_dir = resume.is_null() ? "" : resume_root + "/update_" + std::to_string(resume.at("update").get<int>());
  if (!resume.is_null()) {
    // the data set and the query log as they stood at the resume point
    if (fs::exists(resume_dir + "/dataset.hdf5")) {
      fs::copy_file(resume_dir + "/dataset.hdf5", result.dataset + ".resumed", fs::copy_options::overwrite_existing);
      fs::rename(result.dataset + ".resumed", result.dataset);
    } else {
      fs::remove(result.dataset);
    }
    if (fs::exists(log_path)) fs::resize_file(log_path, resume.at("log_bytes").get<uintmax_t>());
  }
  write_text(o.out + "/config.json", config_text);

  auto env = make_env(config.task);
  auto expert = make_expert(config.task, config.expert);
  MethodConfig method_config = config.method;
  method_config.compare_scores.clear();  // an RQ1 instrument (eval); the session acts on the main rule alone
  auto method = make_method(o.method, config.policy, method_config, config.dagger.seed);
  DatasetWriter writer(result.dataset, env_args(config.task));
  TrainConfig train = config.train;
  // Fine-tuning updates add up their steps: BC, trained once, gets as many. From-scratch updates train
  // by the epoch rule on what they have, and so does BC on its N_f demonstrations.
  if (!method->gated() && !train.from_scratch) train.steps *= bc_budget_factor(config.dagger);
  DaggerSession session(*env, *expert, *method, config.dagger, train, &writer);
  if (!resume.is_null()) {
    method->load_state(resume_dir + "/method");
    session.load_state(resume_dir + "/session");
    result.queries = resume.at("queries").get<int>();
    result.timeouts = resume.at("timeouts").get<int>();
    result.iteration_inference_s = resume.at("iteration_inference_s").get<std::vector<double>>();
    for (const UpdateReport& r : session.reports()) {
      result.iteration_train_s.push_back(r.train_s);
      result.iteration_threshold_s.push_back(r.threshold_s);
    }
    result.resumed_from_update = session.updates();
    if (!o.quiet || !o.label.empty())
      fmt::print(stderr, "{}resuming {} after update {} (episode {})\n", prefix, o.out, session.updates(),
                 session.episode());
  }
  // After an update: everything continuing needs, in a folder of its own, then latest.json pointing at
  // it (a run killed while saving keeps the previous point), then the older points go.
  auto save_resume_point = [&] {
    const int n = session.updates();
    const std::string dir = resume_root + "/update_" + std::to_string(n);
    fs::remove_all(dir);
    method->save_state(dir + "/method");
    session.save_state(dir + "/session");
    if (fs::exists(result.dataset)) fs::copy_file(result.dataset, dir + "/dataset.hdf5");
    const nlohmann::json point{{"update", n},
                               {"log_bytes", fs::exists(log_path) ? fs::file_size(log_path) : 0},
                               {"queries", result.queries},
                               {"timeouts", result.timeouts},
                               {"iteration_inference_s", result.iteration_inference_s}};
    write_text(resume_root + "/latest.json", point.dump(2) + "\n");
    for (const auto& entry : fs::directory_iterator(resume_root))
      if (entry.is_directory() && entry.path().filename() != "update_" + std::to_string(n)) fs::remove_all(entry.path());
  };
  EventLog log(log_path);
  session.add_observer([&log](const SessionEvent& e) { log(e); });
  session.add_observer([&](const SessionEvent& e) {
    if (e.kind == EventKind::kQuery) ++result.queries;
    if (e.kind == EventKind::kTimeout) ++result.timeouts;
    if (e.kind == EventKind::kEpisodeEnd && !o.quiet) {
      const char* how = e.gave_up ? "the expert gave up"
                        : e.control == Control::kRobot ? (e.success ? "robot succeeded" : "robot failed")
                        : e.control == Control::kExpertDemo ? "expert demonstration"
                        : e.control == Control::kExpertQuery ? "robot asked, expert finished"
                                                             : "time limit, expert finished";
      fmt::print(stderr, "episode {:3}: {:30} ({} steps)  demos {}/{}\n", e.episode, how, e.step, e.expert_demos,
                 config.dagger.final_demos);
    }
  });

  // eval's cells (quiet, labelled): between updates, a line every 5 minutes (lines_every_s) on the rollouts so far, so
  // that the hour a good policy can roll out before its next N_d interventions shows in the cell's log
  struct Since {
    int episodes = 0, robot_successes = 0, demos_at_update = 0;
    uint64_t decisions = 0;
  } since;
  since.demos_at_update = session.expert_demos();
  auto last_line = std::chrono::steady_clock::now();
  if (o.quiet && !o.label.empty())
    session.add_observer([&](const SessionEvent& e) {
      if (e.kind == EventKind::kDecision) ++since.decisions;
      if (e.kind == EventKind::kEpisodeEnd) {
        ++since.episodes;
        if (e.control == Control::kRobot && e.success) ++since.robot_successes;
      }
      if (e.kind == EventKind::kUpdateFinished) {
        since = {0, 0, e.expert_demos, 0};
        last_line = std::chrono::steady_clock::now();
      }
      if (e.kind != EventKind::kEpisodeEnd) return;
      const auto now = std::chrono::steady_clock::now();
      if (std::chrono::duration<double>(now - last_line).count() < o.lines_every_s) return;
      last_line = now;
      const int needed = session.updates() == 0 ? config.dagger.initial_demos : config.dagger.demos_per_update;
      fmt::print(stderr, "{}since update {}: {} episodes ({} the robot's own successes), {} of {} demonstrations for update {}, "
                 "{} decisions at {:.0f} ms\n",
                 prefix, session.updates(), since.episodes, since.robot_successes, e.expert_demos - since.demos_at_update, needed,
                 session.updates() + 1, since.decisions,
                 since.decisions == 0 ? 0.0 : 1e3 * session.inference_s_since_update() / static_cast<double>(since.decisions));
    });

  while (!session.done()) {
    if (session.update_pending()) {
      const double inference = session.inference_s_since_update();
      {
        // eval's cells (quiet, labelled): a plain line every 5 minutes, so that an update of an hour
        // or more shows its progress in the cell's log
        ProgressBar bar(fmt::format("{}update {} ({} demos)", prefix, session.updates() + 1, session.expert_demos()), "loss");
        if (o.quiet && !o.label.empty()) bar.lines_every(o.lines_every_s);
        session.run_update(o.quiet && o.label.empty() ? ProgressFn{} : bar.fn());
      }
      const UpdateReport& r = session.reports().back();
      if (session.updates() > 1) result.iteration_inference_s.push_back(inference);
      result.iteration_train_s.push_back(r.train_s);
      result.iteration_threshold_s.push_back(r.threshold_s);
      const std::string dir = o.out + "/checkpoints/update_" + std::to_string(session.updates());
      make_dirs(dir);
      method->save(dir);
      // One line per update: alone on an interactive run, after the label in eval's cell logs (there it is a
      // long run's only sign of life), nothing on a quiet unlabelled one.
      if (!o.quiet || !o.label.empty())
        fmt::print(stderr, "{}update {}: {}/{} demonstrations ({} interventions) in {} episodes, {} pairs; train {:.1f} s{}, "
                   "threshold {:.4g} set in {:.1f} s{}\n",
                   prefix, session.updates(), session.expert_demos(), config.dagger.final_demos,
                   session.interventions(), session.episode(), r.pairs, r.train_s,
                   r.train_reused ? " (when trained: the same members on the same data, loaded from the cache)" : "", r.threshold,
                   r.threshold_s,
                   r.threshold_pairs > 0 ? fmt::format(" ({} of {} pairs at {} rows)", r.threshold_refined, r.threshold_pairs,
                                                       config.method.loss_samples)
                                         : "");
      if (!session.done()) {
        save_resume_point();
        if (session.updates() == o.stop_after_update) {
          result.stopped = true;
          result.updates = session.updates();
          return result;
        }
      }
      continue;
    }
    session.tick();
  }
  fs::remove_all(resume_root);
  result.episodes = session.episode();
  result.expert_demos = session.expert_demos();
  result.interventions = session.interventions();
  result.updates = session.updates();
  for (double v : result.iteration_train_s) result.train_s += v;
  for (double v : result.iteration_threshold_s) result.threshold_s += v;
  for (double v : result.iteration_inference_s) result.inference_s += v;
  if (method_out) *method_out = std::move(method);
  return result;
}

void use_checkpoint_network(ExperimentConfig& config, const std::string& checkpoint) {
  const PolicyConfig p = DiffusionPolicy::from_checkpoint(checkpoint)->config();
  if (p.obs_dim != config.policy.obs_dim || p.action_dim != config.policy.action_dim)
    throw Error(fmt::format("{}: the policy takes {} observation and {} action features per step; task '{}' has {} and {}", checkpoint,
                            p.obs_dim, p.action_dim, config.task, config.policy.obs_dim, config.policy.action_dim));
  config.policy = p;
  config.dagger.action_steps = p.action_steps;
}

TrainRunResult run_train(const ExperimentConfig& preset_config, const TrainOptions& o) {
  ExperimentConfig config = preset_config;
  if (!o.init.empty()) use_checkpoint_network(config, o.init);
  config.validate();
  if (o.out.empty()) throw Error("train: an output folder is required (--out)");
  make_dirs(o.out);
  TrainRunResult result;
  std::vector<Episode> demos;
  if (!o.data.empty()) {
    DatasetInfo info;
    for (const RecordedEpisode& e : read_dataset(o.data, &info)) {
      if (!e.success) continue;  // failed episodes stay in the file, flagged, and out of training
      if (o.demos > 0 && static_cast<int>(demos.size()) >= o.demos) break;
      demos.push_back(e.expert_steps());
    }
    if (info.obs_dim != config.policy.obs_dim || info.action_dim != config.policy.action_dim)
      throw Error(fmt::format("{}: observations {} and actions {} per step, but preset '{}' expects {} and {}", o.data, info.obs_dim,
                              info.action_dim, config.preset, config.policy.obs_dim, config.policy.action_dim));
    if (o.demos > 0 && static_cast<int>(demos.size()) < o.demos)
      throw Error(fmt::format("{}: holds {} successful episodes, fewer than --demos {}", o.data, demos.size(), o.demos));
  } else {
    if (o.demos <= 0) throw Error("train: without --data, --demos N says how many demonstrations to collect");
    demos = collect_demos(config.task, config.expert, o.demos, config.dagger.seed);
  }
  if (demos.empty()) throw Error("train: no successful expert episodes to train on");
  result.demos = static_cast<int>(demos.size());
  // A stopped run left a resume point (out/resume): continue it when it is the same run.
  const std::string resume_dir = o.out + "/resume", config_text = to_json_text(config) + "\n";
  // {"step", "train_s", "eval_s"} of the resume point, null for a fresh run
  const nlohmann::json resume = read_resume_point(o.out, resume_dir + "/progress.json", config, {"step"});
  write_text(o.out + "/config.json", config_text);

  DiffusionPolicy policy(config.policy, config.train.seed);
  if (!resume.is_null()) policy.load(resume_dir + "/policy.pt");
  else if (!o.init.empty()) policy.load(o.init);
  const ChunkDataset data = ChunkDataset::from_episodes(demos, config.policy.horizon);
  result.pairs = data.size();
  auto env = make_env(config.task);
  auto actor = act_with(policy);
  const DaggerConfig& d = config.dagger;
  const int resume_step = resume.is_null() ? 0 : resume.at("step").get<int>();
  {  // curve.csv: a fresh file, or the rows up to the resume point
    std::string kept = "step,success_rate,episodes,demos,outcomes\n";
    if (resume_step > 0) {
      std::istringstream rows(read_text(o.out + "/curve.csv"));
      std::string line;
      std::getline(rows, line);
      while (std::getline(rows, line)) {
        const int step = std::stoi(line.substr(0, line.find(',')));
        if (step > resume_step) continue;
        kept += line + "\n";
        const size_t a = line.find(',') + 1;
        result.curve.emplace_back(step, std::stod(line.substr(a, line.find(',', a) - a)));
        result.success = result.curve.back().second;
      }
    }
    write_text(o.out + "/curve.csv", kept);
  }
  std::ofstream curve_csv(o.out + "/curve.csv", std::ios::app);
  auto evaluate = [&](int step, int episodes) {
    const auto t = std::chrono::steady_clock::now();
    std::vector<RolloutResult> results;
    {
      ProgressBar bar(fmt::format("rollouts after {} steps", step), "success");
      results = evaluate_rollouts(*env, *actor, episodes, RolloutSpec::of(d), o.eval_seed, o.quiet ? ProgressFn{} : bar.fn());
    }
    result.eval_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
    result.curve.emplace_back(step, success_rate(results));
    result.success = success_rate(results);
    const std::string outcomes = outcome_counts(results);
    curve_csv << fmt::format("{},{:.4f},{},{},\"{}\"\n", step, result.success, episodes, result.demos, outcomes) << std::flush;
    if (!o.quiet) fmt::print(stderr, "after {} steps: success {:.2f} over {} rollouts ({})\n", step, result.success, episodes, outcomes);
  };

  std::vector<float> losses;
  auto write_losses = [&] {
    std::string loss_csv = "step,loss\n";
    for (size_t i = 0; i < losses.size(); ++i) loss_csv += fmt::format("{},{:.6g}\n", i + 1, losses[i]);
    write_text(o.out + "/losses.csv", loss_csv);
  };
  if (resume_step > 0) {  // the losses up to the resume point
    std::istringstream rows(read_text(o.out + "/losses.csv"));
    std::string line;
    std::getline(rows, line);
    while (static_cast<int>(losses.size()) < resume_step && std::getline(rows, line))
      losses.push_back(std::stof(line.substr(line.find(',') + 1)));
    if (static_cast<int>(losses.size()) != resume_step)
      throw Error(o.out + "/losses.csv: holds " + std::to_string(losses.size()) + " steps, the resume point is at " +
                  std::to_string(resume_step));
    result.train_s = resume.value("train_s", 0.0);
    result.eval_s = resume.value("eval_s", 0.0);
    if (!o.quiet) fmt::print(stderr, "resuming {} at step {}\n", o.out, resume_step);
  }
  const int steps = config.train.steps_for(data.size());
  if (steps > 0) {
    Trainer trainer(policy, data, config.train);
    if (resume_step > 0) trainer.resume(resume_dir + "/trainer.pt");
    // a resume point: the policy, the trainer's state, the losses and the times so far
    auto save_resume_point = [&](int step) {
      make_dirs(resume_dir);
      policy.save(resume_dir + "/policy.pt");
      trainer.save_state(resume_dir + "/trainer.pt");
      write_losses();
      write_text(resume_dir + "/progress.json",
                 nlohmann::json{{"step", step}, {"train_s", result.train_s}, {"eval_s", result.eval_s}}.dump() + "\n");
    };
    ProgressBar bar(fmt::format("train {} on {} demonstrations ({} pairs)", config.task, result.demos, result.pairs), "loss");
    bar.resume_from(trainer.steps_done());
    auto t = std::chrono::steady_clock::now();
    auto count_train_time = [&] {
      const auto now = std::chrono::steady_clock::now();
      result.train_s += std::chrono::duration<double>(now - t).count();
      t = now;
    };
    for (int i = trainer.steps_done() + 1; i <= steps; ++i) {
      losses.push_back(trainer.step());
      if (!o.quiet) bar.update(i, steps, losses.back());
      const bool curve_point = o.eval_episodes > 0 && o.eval_every > 0 && i % o.eval_every == 0 && i < steps;
      if (curve_point) {
        count_train_time();
        evaluate(i, o.curve_episodes > 0 ? o.curve_episodes : o.eval_episodes);
        t = std::chrono::steady_clock::now();
      }
      if (curve_point || i == steps || (o.save_every > 0 && i % o.save_every == 0) || i == o.stop_after) {
        count_train_time();
        save_resume_point(i);
        if (i == o.stop_after && i < steps) {
          if (!o.quiet) fmt::print(stderr, "stopped after step {}; the same command continues from {}\n", i, resume_dir);
          result.stopped = true;
          return result;
        }
      }
    }
  }
  const size_t tail = std::min<size_t>(losses.size(), 100);
  result.final_loss = tail == 0 ? NAN : std::accumulate(losses.end() - tail, losses.end(), 0.0) / tail;
  policy.save(o.out + "/policy.pt");
  write_losses();
  if (o.eval_episodes > 0) evaluate(steps, o.eval_episodes);
  if (!o.threshold.empty()) {
    if (o.threshold != "screened" && o.threshold != "both") throw Error("train: --threshold is screened or both, got '" + o.threshold + "'");
    policy.set_score_weights(config.method.score_raw_weights ? ScoreWeights::kRaw : ScoreWeights::kEma);
    policy.set_score_space(score_space_from(config.method.score_space));
    policy.set_score_timesteps(config.method.score_timesteps);
    auto set = [&](bool screen) {
      ProgressBar bar(screen ? "threshold, screened" : "threshold, every pair at all rows", "loss");
      const auto t = std::chrono::steady_clock::now();
      const LossQuantile q = policy.loss_quantile(data, config.method.alpha, config.dagger.seed * 31 + 1, config.method.loss_samples,
                                                  screen, o.quiet ? ProgressFn{} : bar.fn());
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
      if (!o.quiet) fmt::print(stderr, "threshold {:.5f} in {:.1f} s ({} of {} pairs at {} rows)\n", q.threshold, s, q.refined, q.pairs,
                               config.method.loss_samples);
      return nlohmann::json{{"threshold", q.threshold}, {"seconds", s}, {"refined", q.refined}, {"screen_samples", q.screen_samples}};
    };
    result.threshold["screened"] = set(true);
    if (o.threshold == "both") result.threshold["all_rows"] = set(false);
    result.threshold["alpha"] = config.method.alpha;
    result.threshold["loss_samples"] = config.method.loss_samples;
  }
  const nlohmann::json summary{{"task", config.task}, {"preset", config.preset}, {"expert", config.expert}, {"demos", result.demos},
                               {"pairs", result.pairs}, {"steps", steps}, {"obs_dim", config.policy.obs_dim}, {"batch_size", config.train.batch_size},
                               {"train_s", result.train_s}, {"eval_s", result.eval_s}, {"final_loss", result.final_loss},
                               {"episodes", o.eval_episodes}, {"success_rate", o.eval_episodes > 0 ? result.success : -1.0},
                               {"eval_seed", o.eval_seed}, {"threshold", result.threshold}};
  write_text(o.out + "/summary.json", summary.dump(2) + "\n");
  std::error_code ec;
  fs::remove_all(resume_dir, ec);  // done: policy.pt and summary.json are the run's result
  return result;
}

int write_learning_curves(const std::string& dir) {
  struct Run {
    std::string cell, task, expert;
    int demos = 0, steps = 0, episodes = 0, obs_dim = 0;
    double success = NAN;
    std::vector<std::pair<double, double>> curve;
  };
  std::vector<Run> runs;
  if (!fs::is_directory(dir)) throw Error(dir + ": no such folder");
  for (const auto& entry : fs::directory_iterator(dir)) {
    const std::string summary = entry.path().string() + "/summary.json";
    if (!entry.is_directory() || !fs::exists(summary)) continue;
    Run r;
    r.cell = entry.path().filename().string();
    try {
      std::ifstream f(summary);
      const nlohmann::json j = nlohmann::json::parse(f);
      r.task = j.at("task").get<std::string>();
      r.expert = j.at("expert").get<std::string>();
      r.demos = j.at("demos").get<int>();
      r.steps = j.at("steps").get<int>();
      r.episodes = j.at("episodes").get<int>();
      r.success = j.at("success_rate").get<double>();
      r.obs_dim = j.value("obs_dim", 0);
    } catch (const std::exception& e) {
      throw Error(summary + ": not a train summary (" + e.what() + ")");
    }
    std::ifstream c(entry.path().string() + "/curve.csv");
    std::string line;
    std::getline(c, line);  // header
    while (std::getline(c, line)) {
      double step = 0, success = 0;
      if (std::sscanf(line.c_str(), "%lf,%lf", &step, &success) == 2) r.curve.emplace_back(step, success);
    }
    if (r.episodes > 0) runs.push_back(std::move(r));
  }
  std::sort(runs.begin(), runs.end(), [](const Run& a, const Run& b) {
    return std::tie(a.task, a.expert, a.demos, a.steps, a.cell) < std::tie(b.task, b.expert, b.demos, b.steps, b.cell);
  });
  std::string csv = "cell,task,expert,demos,steps,success_rate,episodes\n";
  for (const Run& r : runs)
    csv += fmt::format("{},{},{},{},{},{:.3f},{}\n", r.cell, r.task, r.expert, r.demos, r.steps, r.success, r.episodes);
  write_text(dir + "/curves.csv", csv);

  // ten distinct colours (the Tableau 10 set), so that up to ten runs never share one
  const ui::Rgb palette[] = {{78, 121, 167}, {242, 142, 43}, {89, 161, 79},  {225, 87, 89},   {118, 183, 178},
                             {237, 201, 72}, {176, 122, 161}, {255, 157, 167}, {156, 117, 95}, {186, 176, 172}};
  constexpr size_t kColors = sizeof(palette) / sizeof(palette[0]);
  ui::LinePanel by_demos;
  by_demos.title = "BC success against demonstrations";
  by_demos.x_label = "demonstrations";
  by_demos.y_label = "success rate";
  by_demos.y_min = 0, by_demos.y_max = 1;
  std::map<std::string, size_t> line_of;  // task/expert/steps -> series
  for (const Run& r : runs) {
    const std::string key = fmt::format("{} ({}), {} steps, obs {}", r.task, r.expert, r.steps, r.obs_dim);
    if (!line_of.count(key)) {
      line_of[key] = by_demos.series.size();
      by_demos.series.push_back({key, {}, {}, palette[by_demos.series.size() % kColors]});
    }
    auto& s = by_demos.series[line_of[key]];
    s.x.push_back(r.demos);
    s.y.push_back(r.success);
  }
  ui::LinePanel by_steps;
  by_steps.title = "BC success against training steps";
  by_steps.x_label = "training steps";
  by_steps.y_label = "success rate";
  by_steps.y_min = 0, by_steps.y_max = 1;
  for (const Run& r : runs) {
    if (r.curve.size() < 2) continue;
    ui::LineSeries s{fmt::format("{}: {} ({}), {} demos", r.cell, r.task, r.expert, r.demos), {}, {}, palette[by_steps.series.size() % kColors]};
    for (const auto& [step, success] : r.curve) s.x.push_back(step), s.y.push_back(success);
    by_steps.series.push_back(std::move(s));
  }
  ui::write_png(dir + "/success_vs_demos.png", ui::hstack({ui::draw_lines(by_demos)}, fmt::format("{} run{}; rollouts per point in curves.csv", runs.size(), runs.size() == 1 ? "" : "s")));
  if (!by_steps.series.empty()) ui::write_png(dir + "/success_vs_steps.png", ui::hstack({ui::draw_lines(by_steps)}));
  return static_cast<int>(runs.size());
}


}  // namespace dd::app
