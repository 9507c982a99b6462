// Interactive learning on the 2-D toy, end to end with real policies: a quick Diff-DAgger run ends no
// worse than BC with the same expert budget, and the quick evaluation writes every report file.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "app/experiments.h"
#include "app/experiments/shared.h"
#include "core/dataset.h"
#include "core/evaluation.h"
#include "core/text_file.h"
#include "core/method.h"
#include "envs/registry.h"
#include "ui/image_io.h"

namespace dd::app {
namespace {

namespace fs = std::filesystem;

std::string temp_dir(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("dd_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(p);
  return p.string();
}

// A CSV file's rows as header name -> field (a field in double quotes may hold commas: an outcome
// such as "turned, off in position"; the experiments write no quote inside one).
std::vector<std::map<std::string, std::string>> read_csv(const std::string& path) {
  auto fields = [](const std::string& line) {
    std::vector<std::string> out(1);
    bool quoted = false;
    for (char ch : line) {
      if (ch == '"') quoted = !quoted;
      else if (ch == ',' && !quoted) out.emplace_back();
      else out.back() += ch;
    }
    return out;
  };
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);
  const std::vector<std::string> names = fields(line);
  std::vector<std::map<std::string, std::string>> rows;
  while (std::getline(in, line)) {
    const std::vector<std::string> f = fields(line);
    auto& row = rows.emplace_back();
    for (size_t i = 0; i < names.size() && i < f.size(); ++i) row[names[i]] = f[i];
  }
  return rows;
}

ExperimentConfig quick_config() {
  ExperimentConfig c = preset("nav2d_random");
  EvalOptions e;
  e.apply_quick(c);
  return c;
}

// The smallest evaluation that exercises every code path: 4 rollouts a measurement, ensembles of 2,
// 30 steps at batch 32 (plumbing only); `c` is set to match.
EvalOptions tiny_eval(ExperimentConfig& c) {
  c = quick_config();
  EvalOptions e;
  e.apply_quick(c);
  e.episodes = 4;
  c.method.members = 2;
  c.train.batch_size = 32;
  c.train.steps = 30;
  c.method.critic.steps = 50;
  return e;
}

}  // namespace

// Reports quote spread over a handful of seeds, so it is the sample standard deviation (n - 1).
TEST(Report, SpreadOverSeedsIsTheSampleStandardDeviation) {
  const auto [m, s] = mean_std({0.85, 0.88, 0.77});
  EXPECT_NEAR(m, 0.8333, 1e-4);
  EXPECT_NEAR(s, 0.0569, 1e-4);  // the population formula would give 0.0465
  EXPECT_EQ(mean_std({0.5}).second, 0.0);
  EXPECT_TRUE(std::isnan(mean_std({}).first));
}

// Values from the hypergeometric law, summed by hand (math.comb) outside this code.
TEST(Report, FisherExactTestOfAskingAgainstFailing) {
  EXPECT_NEAR(fisher_exact_p(3, 1, 1, 3), 0.4857, 1e-4);          // the tea-tasting table
  EXPECT_NEAR(fisher_exact_p(23, 18, 31, 28), 0.8388, 1e-4);      // push_1expert, Diff-DAgger, seed 0
  EXPECT_NEAR(fisher_exact_p(12, 6, 42, 40), 0.2999, 1e-4);       // push_1expert, the ensemble's spread
  EXPECT_NEAR(fisher_exact_p(10, 0, 0, 10), 1.0825e-5, 1e-8);     // a perfect rule, 10 failures in 20
  EXPECT_NEAR(fisher_exact_p(0, 10, 10, 0), 1.0825e-5, 1e-8);     // two-sided: a perfectly wrong rule too
  EXPECT_LT(fisher_exact_p(177, 12, 5, 106), 1e-50);              // stacking's three seeds pooled
  EXPECT_DOUBLE_EQ(fisher_exact_p(0, 0, 5, 5), 1.0);              // a rule that never asks tells nothing
  EXPECT_THROW(fisher_exact_p(-1, 0, 0, 0), Error);
}

TEST(Report, MantelHaenszelTestOfAskingAgainstFailingWithinSeeds) {
  // a perfect rule on one seed: (|10 - 5| - 0.5)^2 / (10^4 / (20^2 * 19)) = 15.39, P(chi2_1 > 15.39)
  EXPECT_NEAR(mantel_haenszel_p({{10, 0, 0, 10}}), 8.745e-5, 1e-8);
  // Simpson: on each seed the rule asks as often in successes as in failures (90% and 10%), but one
  // seed's policy fails 90% of the time and the other's 10%: summed, asking goes with failing
  EXPECT_LT(fisher_exact_p(82, 18, 18, 82), 1e-15);
  EXPECT_NEAR(mantel_haenszel_p({{81, 9, 9, 1}, {1, 9, 9, 81}}), 1.0, 1e-9);
  // the same association on three seeds is firmer than on any one of them
  const AskFailTable seed{12, 4, 6, 10};
  EXPECT_LT(mantel_haenszel_p({seed, seed, seed}), mantel_haenszel_p({seed}) / 10);
  EXPECT_NEAR(mantel_haenszel_p({{23, 18, 31, 28}, {14, 13, 40, 33}, {18, 6, 50, 26}}), 0.7064, 1e-4);  // push_1expert, Diff-DAgger
  EXPECT_DOUBLE_EQ(mantel_haenszel_p({{0, 0, 5, 5}, {0, 0, 3, 7}}), 1.0);  // never asks
  EXPECT_DOUBLE_EQ(mantel_haenszel_p({}), 1.0);
  EXPECT_THROW(mantel_haenszel_p({{-1, 0, 0, 0}}), Error);
}

TEST(DaggerNav2d, DiffDaggerIsNoWorseThanBcWithTheSameExpertBudget) {
  const ExperimentConfig c = quick_config();
  auto env = make_env(c.task);
  double success[2] = {0, 0};
  const char* methods[2] = {"diff", "bc"};
  for (int i = 0; i < 2; ++i) {
    DaggerRunOptions o;
    o.method = methods[i];
    o.out = temp_dir(std::string("dagger_") + methods[i]);
    o.quiet = true;
    std::unique_ptr<Method> trained;
    const DaggerRunResult r = run_dagger(c, o, &trained);
    EXPECT_EQ(r.expert_demos, c.dagger.final_demos) << methods[i];
    EXPECT_EQ(read_dataset(r.dataset).size(), static_cast<size_t>(c.dagger.final_demos));
    EXPECT_TRUE(fs::exists(o.out + "/queries.jsonl"));
    EXPECT_TRUE(fs::exists(o.out + "/checkpoints/update_1/policy.pt"));
    if (o.method == "diff") {
      // every decision says over how many rows its loss was scored; one scored with fewer than N_b
      // (the screened gate stopped early) lies below the threshold
      std::ifstream log(o.out + "/queries.jsonl");
      int decisions = 0;
      for (std::string l; std::getline(log, l);) {
        const nlohmann::json j = nlohmann::json::parse(l);
        if (j["event"] != "decision") continue;
        ++decisions;
        const int rows = j.at("score_rows").get<int>();
        EXPECT_GE(rows, 1);
        EXPECT_LE(rows, c.method.loss_samples);
        if (rows < c.method.loss_samples) {
          EXPECT_LT(j["score"].get<double>(), j["threshold"].get<double>());
        }
      }
      EXPECT_GT(decisions, 0);
    }
    const auto results = evaluate_rollouts(*env, *trained, 20, RolloutSpec::of(c.dagger), 4242);
    success[i] = success_rate(results);
    fs::remove_all(o.out);
  }
  RecordProperty("diff_success", std::to_string(success[0]));
  RecordProperty("bc_success", std::to_string(success[1]));
  std::printf("quick nav2d_random: Diff-DAgger success %.2f, BC success %.2f (20 rollouts each)\n", success[0], success[1]);
  EXPECT_GE(success[0], success[1]);
}

// A DAgger run stopped after an update and run again ends where an unstopped run ends: the same
// episodes, queries, data set, query log (timings aside) and final policies.
TEST(DaggerNav2d, AStoppedRunContinuesFromItsLastUpdate) {
  ExperimentConfig c = quick_config();
  c.dagger.max_episodes = 40;  // a robot that rarely asks would otherwise roll out 150 episodes
  c.method.critic.steps = 50;
  const std::string root = temp_dir("dagger_resume");
  auto events = [](const std::string& path) {  // the query log without its timings
    std::vector<nlohmann::json> v;
    std::ifstream f(path);
    for (std::string line; std::getline(f, line);) {
      nlohmann::json j = nlohmann::json::parse(line);
      for (const char* timing : {"inference_ms", "train_s", "threshold_s"}) j.erase(timing);
      v.push_back(j);
    }
    return v;
  };
  for (const char* method : {"thrifty", "diff"}) {
    SCOPED_TRACE(method);
    DaggerRunOptions o;
    o.method = method;
    o.quiet = true;
    o.out = root + "/" + method + "_straight";
    std::unique_ptr<Method> straight_method, resumed_method;
    // as eval's cells run it (quiet, labelled), with its progress lines as often as they come
    DaggerRunOptions labelled = o;
    labelled.label = "[cell]";
    labelled.lines_every_s = 0;
    testing::internal::CaptureStderr();
    const DaggerRunResult straight = run_dagger(c, labelled, &straight_method);
    const std::string said = testing::internal::GetCapturedStderr();
    EXPECT_NE(said.find("[cell] since update 1: "), std::string::npos) << said.substr(0, 2000);
    EXPECT_NE(said.find("[cell] update 2: "), std::string::npos) << said.substr(0, 2000);
    const std::string rows_note = fmt::format(" pairs at {} rows)", c.method.loss_samples);
    EXPECT_EQ(said.find(rows_note) != std::string::npos, std::string(method) == "diff")
        << "Diff-DAgger's update lines say how many pairs its screened threshold scored in full";
    std::printf("%s: %d episodes, %d updates, %d queries, %d time-outs\n", method, straight.episodes, straight.updates,
                straight.queries, straight.timeouts);
    ASSERT_GE(straight.updates, 3) << "the test stops the run after its second update";
    EXPECT_FALSE(fs::exists(o.out + "/resume")) << "a finished run keeps no resume point";

    DaggerRunOptions s = o;
    s.out = root + "/" + method + "_stopped";
    s.stop_after_update = 2;
    const DaggerRunResult stopped = run_dagger(c, s);
    EXPECT_TRUE(stopped.stopped);
    EXPECT_TRUE(fs::exists(s.out + "/resume/latest.json"));
    s.stop_after_update = 0;
    const DaggerRunResult resumed = run_dagger(c, s, &resumed_method);
    EXPECT_FALSE(resumed.stopped);
    EXPECT_EQ(resumed.resumed_from_update, 2);
    EXPECT_FALSE(fs::exists(s.out + "/resume"));

    EXPECT_EQ(resumed.episodes, straight.episodes);
    EXPECT_EQ(resumed.expert_demos, straight.expert_demos);
    EXPECT_EQ(resumed.interventions, straight.interventions);
    EXPECT_EQ(resumed.queries, straight.queries);
    EXPECT_EQ(resumed.timeouts, straight.timeouts);
    EXPECT_EQ(resumed.updates, straight.updates);
    EXPECT_EQ(resumed.iteration_train_s.size(), straight.iteration_train_s.size());
    EXPECT_EQ(resumed.iteration_inference_s.size(), straight.iteration_inference_s.size());
    EXPECT_EQ(events(s.out + "/queries.jsonl"), events(o.out + "/queries.jsonl"));
    // Diff-DAgger's threshold scored in full at least every pair at or above its quantile
    int updates_logged = 0;
    for (const nlohmann::json& e : events(o.out + "/queries.jsonl")) {
      if (e.at("event") != "update_finished") continue;
      ++updates_logged;
      if (std::string(method) != "diff") {
        EXPECT_FALSE(e.contains("threshold_refined"));
        continue;
      }
      const int pairs = e.at("threshold_pairs").get<int>(), refined = e.at("threshold_refined").get<int>();
      EXPECT_LE(refined, pairs);
      EXPECT_GE(refined, pairs - static_cast<int>(std::floor(pairs * c.method.alpha))) << e.dump();
    }
    EXPECT_EQ(updates_logged, straight.updates);
    const auto a = read_dataset(straight.dataset), b = read_dataset(resumed.dataset);
    ASSERT_EQ(a.size(), b.size());
    for (size_t i = 0; i < a.size(); ++i) {
      EXPECT_TRUE(a[i].obs.isApprox(b[i].obs, 1e-6f) || a[i].obs == b[i].obs) << "episode " << i;
      EXPECT_EQ(a[i].intervention, b[i].intervention) << "episode " << i;
    }
    EXPECT_FLOAT_EQ(resumed_method->threshold(), straight_method->threshold());
    auto env = make_env(c.task);
    env->reset(77);
    const MethodDecision da = straight_method->decide(env->observation(), 5), db = resumed_method->decide(env->observation(), 5);
    EXPECT_TRUE(da.chunk.isApprox(db.chunk, 1e-5f));
    EXPECT_NEAR(da.score, db.score, 1e-5f * std::abs(da.score) + 1e-7f);
    EXPECT_EQ(da.violation, db.violation);
  }

  // a stopped run's folder refuses a run with another config
  DaggerRunOptions o;
  o.method = "diff";
  o.quiet = true;
  o.out = root + "/other";
  o.stop_after_update = 1;
  run_dagger(c, o);
  ExperimentConfig other = c;
  other.train.steps += 10;
  o.stop_after_update = 0;
  try {
    run_dagger(other, o);
    ADD_FAILURE() << "a different config resumed another run";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(o.out + "/config.json"), std::string::npos) << e.what();
  }
  fs::remove_all(root);
}

// eval trains one ensemble per seed for RQ1; each method adopting it must act and ask exactly as if
// its own update had trained it (Diff-DAgger's policy is member 0).
TEST(DaggerNav2d, SharedRq1PoliciesAreWhatEachMethodsOwnUpdateTrains) {
  const ExperimentConfig c = quick_config();
  const std::string dir = temp_dir("rq1_policies");
  const auto demos = collect_demos(c.task, c.expert, c.rq1_demos, c.dagger.seed);
  const std::vector<std::string> paths = rq1_policies(c, c.method.members, demos, dir, "test");
  ASSERT_EQ(paths.size(), static_cast<size_t>(c.method.members));
  const auto written = fs::last_write_time(paths[0]);
  EXPECT_EQ(rq1_policies(c, 1, demos, dir, "test").size(), 1u);
  EXPECT_EQ(fs::last_write_time(paths[0]), written) << "a member already trained is not trained again";

  auto env = make_env(c.task);
  // (the ensemble methods adopt every member; their update trains each through the same train_member)
  for (const char* name : {"diff"}) {
    SCOPED_TRACE(name);
    auto own = make_method(name, c.policy, c.method, c.dagger.seed);
    auto adopted = make_method(name, c.policy, c.method, c.dagger.seed);
    // an update shows progress through its training and then through its threshold's scoring pass
    std::vector<std::pair<int, int>> parts;  // (last done, total) of each part
    own->update(demos, {}, rq1_training(c), [&](int done, int total, double) {
      if (parts.empty() || parts.back().second != total || done < parts.back().first) parts.emplace_back(done, total);
      parts.back().first = done;
    });
    ASSERT_EQ(parts.size(), 2u) << "training, then the threshold";
    EXPECT_EQ(parts[0], std::make_pair(rq1_training(c).steps, rq1_training(c).steps));
    EXPECT_EQ(parts[1].first, parts[1].second) << "the threshold's pass ends at its total";
    adopted->adopt(std::string(name) == "diff" ? std::vector<std::string>{paths[0]} : paths, demos, {}, {});
    EXPECT_FLOAT_EQ(adopted->threshold(), own->threshold());
    for (uint64_t seed : {3u, 11u}) {
      env->reset(seed);
      const MethodDecision a = own->decide(env->observation(), seed), b = adopted->decide(env->observation(), seed);
      EXPECT_TRUE(a.chunk.isApprox(b.chunk, 1e-5f)) << "seed " << seed;
      EXPECT_NEAR(a.score, b.score, 1e-5f * std::abs(a.score) + 1e-8f) << "seed " << seed;
    }
  }

  // Setting the thresholds shows progress over every rule's scoring pass as one count, which ends
  // at its total; the method's own threshold is the one it sets without compared rules.
  MethodConfig with_compared = c.method;
  with_compared.compare_scores = {"epsilon"};
  auto compared = make_method("diff", c.policy, with_compared, c.dagger.seed);
  std::vector<std::pair<int, int>> calls;
  compared->adopt({paths[0]}, demos, {}, [&](int done, int total, double) { calls.emplace_back(done, total); });
  ASSERT_FALSE(calls.empty());
  const int total = calls.front().second;
  int furthest = 0;
  for (const auto& [done, t] : calls) {
    EXPECT_EQ(t, total) << "one count over all the passes";
    EXPECT_GE(done, furthest) << "progress never goes back";
    furthest = std::max(furthest, done);
  }
  EXPECT_EQ(calls.back().first, total);
  EXPECT_TRUE(std::any_of(calls.begin(), calls.end(), [&](const auto& d) { return 2 * d.first < total; }) &&
              std::any_of(calls.begin(), calls.end(), [&](const auto& d) { return 2 * d.first > total && d.first < total; }))
      << "both passes report, each over its own half";
  auto plain = make_method("diff", c.policy, c.method, c.dagger.seed);
  plain->adopt({paths[0]}, demos, {}, {});
  EXPECT_FLOAT_EQ(compared->threshold(), plain->threshold());

  // The ensembles' threshold pass (Thrifty-DAgger's is the same code) counts its members as each
  // has sampled at every pair, and sets the same threshold as without a count.
  std::vector<std::pair<int, int>> counted;
  auto watched = make_method("ensemble", c.policy, c.method, c.dagger.seed), quiet = make_method("ensemble", c.policy, c.method, c.dagger.seed);
  watched->adopt(paths, demos, {}, [&](int done, int total, double) { counted.emplace_back(done, total); });
  ASSERT_EQ(counted.size(), paths.size());
  for (size_t i = 0; i < counted.size(); ++i) EXPECT_EQ(counted[i], std::make_pair(static_cast<int>(i) + 1, static_cast<int>(paths.size())));
  quiet->adopt(paths, demos, {}, {});
  EXPECT_FLOAT_EQ(watched->threshold(), quiet->threshold());
  fs::remove_all(dir);
}

// A run folder's config.json written before a key existed still holds the same config (the key at
// the preset's value); a different value, or a different preset, does not.
TEST(DaggerNav2d, StoredConfigsFromOlderBuildsStillMatch) {
  const ExperimentConfig c = preset("stack");
  const std::string dir = temp_dir("stored_config");
  fs::create_directories(dir);
  const std::string path = dir + "/config.json";
  EXPECT_FALSE(stored_config_matches(path, c)) << "no file";
  nlohmann::json j = nlohmann::json::parse(to_json_text(c));
  write_text(path, j.dump(2));
  EXPECT_TRUE(stored_config_matches(path, c));
  j["method"].erase("score_space");  // as an older build wrote it
  write_text(path, j.dump(2));
  EXPECT_TRUE(stored_config_matches(path, c));
  ExperimentConfig other = c;
  other.method.score_space = "epsilon";
  EXPECT_FALSE(stored_config_matches(path, other));
  other = c;
  other.train.steps += 1;
  EXPECT_FALSE(stored_config_matches(path, other));
  write_text(path, "{not json");
  EXPECT_THROW(stored_config_matches(path, c), Error);
  fs::remove_all(dir);
}

TEST(DaggerNav2d, QuickEvaluationWritesEveryFile) {
  ExperimentConfig c;
  EvalOptions e = tiny_eval(c);
  e.out = temp_dir("eval");
  run_eval(c, e);
  for (const char* f : {"report.md", "rq1.csv", "rq2.csv", "rq3.csv", "rq1_failure_prediction.png", "rq2_success.png", "rq3_wallclock.png"})
    EXPECT_TRUE(fs::exists(e.out + "/" + f)) << f;
  std::ifstream rq1(e.out + "/rq1.csv");
  std::string header, line;
  std::getline(rq1, header);
  EXPECT_EQ(header.rfind("method,tpr,tnr,f1,acc", 0), 0u) << header;
  int rows = 0;
  while (std::getline(rq1, line)) ++rows;
  EXPECT_EQ(rows, 5);  // diff, ensemble, thrifty and its rule's two halves alone (BC has no query rule)
  std::ifstream rq2(e.out + "/rq2.csv");
  std::getline(rq2, header);
  EXPECT_EQ(header.rfind("method,success_rate,n", 0), 0u) << header;
  // counts beside the rates: TP + FP + TN + FN is the number of rollouts of each method
  std::ifstream rq1b(e.out + "/rq1.csv");
  std::getline(rq1b, header);
  EXPECT_NE(header.find(",tp,fp,tn,fn,"), std::string::npos) << header;
  // and each row's Fisher p is the test of those counts
  EXPECT_NE(header.find(",fisher_p"), std::string::npos) << header;
  std::map<std::string, long> asked;  // rollouts each row's rule asked in
  for (auto& f : read_csv(e.out + "/rq1.csv")) {
    const double p = fisher_exact_p(std::stol(f["tp"]), std::stol(f["fp"]), std::stol(f["fn"]), std::stol(f["tn"]));
    EXPECT_NEAR(std::stod(f["fisher_p"]), p, 0.006 * p + 1e-12) << f["method"];  // printed to 3 significant figures
    asked[f["method"]] = std::stol(f["tp"]) + std::stol(f["fp"]);
  }
  // rq1_seeds.csv: each seed's cell, summing to rq1.csv's counts; the rules' thresholds as the rollouts saw them
  std::map<std::string, std::array<long, 4>> by_seed;
  for (auto& f : read_csv(e.out + "/rq1_seeds.csv")) {
    auto& n = by_seed[f["method"]];
    n[0] += std::stol(f["tp"]), n[1] += std::stol(f["fp"]), n[2] += std::stol(f["tn"]), n[3] += std::stol(f["fn"]);
    const bool own_rule = f["method"].find('@') == std::string::npos;
    EXPECT_EQ(std::isfinite(std::stod(f["threshold"])), own_rule) << f["method"];
    EXPECT_EQ(std::isfinite(std::stod(f["risk_threshold"])), f["method"] == "thrifty") << f["method"];
  }
  // rq1_outcomes.csv: the rollouts behind those counts, by how they ended
  std::map<std::string, long> rollouts_of, asked_in, failed_and_asked;
  for (auto& f : read_csv(e.out + "/rq1_outcomes.csv")) {
    rollouts_of[f["method"]] += std::stol(f["rollouts"]);
    asked_in[f["method"]] += std::stol(f["asked"]);
    if (f["success"] == "0") failed_and_asked[f["method"]] += std::stol(f["asked"]);
    EXPECT_LE(std::stol(f["asked"]), std::stol(f["rollouts"]));
  }
  std::map<std::string, std::vector<AskFailTable>> strata;
  for (auto& f : read_csv(e.out + "/rq1_seeds.csv"))
    strata[f["method"]].push_back({std::stol(f["tp"]), std::stol(f["fp"]), std::stol(f["fn"]), std::stol(f["tn"])});
  for (auto& f : read_csv(e.out + "/rq1.csv")) {
    const std::string m = f["method"];
    const double within = mantel_haenszel_p(strata[m]);
    EXPECT_NEAR(std::stod(f["cmh_p"]), within, 0.006 * within + 1e-12) << m;
    EXPECT_EQ(by_seed[m], (std::array<long, 4>{std::stol(f["tp"]), std::stol(f["fp"]), std::stol(f["tn"]), std::stol(f["fn"])})) << m;
    EXPECT_EQ(rollouts_of[m], static_cast<long>(e.seeds) * e.episodes) << m;
    EXPECT_EQ(asked_in[m], asked[m]) << m;
    EXPECT_EQ(failed_and_asked[m], std::stol(f["tp"])) << m;
  }
  // Thrifty's halves on its own rollouts: K violations in a row of either are K of the rule
  ASSERT_TRUE(asked.count("thrifty@novelty") && asked.count("thrifty@risk"));
  EXPECT_LE(asked["thrifty@novelty"], asked["thrifty"]);
  EXPECT_LE(asked["thrifty@risk"], asked["thrifty"]);
  const std::string report = [&] {
    std::ifstream r(e.out + "/report.md");
    std::stringstream ss;
    ss << r.rdbuf();
    return ss.str();
  }();
  EXPECT_NE(report.find("| TP | FP | TN | FN |"), std::string::npos);
  EXPECT_NE(report.find("final iteration"), std::string::npos);
  // RQ3's ratios against Diff-DAgger are those of rq3.csv's means per iteration
  {
    std::map<std::string, double> train_s;
    for (auto& f : read_csv(e.out + "/rq3.csv")) train_s[f["method"]] = std::stod(f["train_s"]);
    const double want = train_s["ensemble"] / train_s["diff"];
    const size_t at = report.find("| Ensemble-DAgger | ", report.find("| Method / Diff-DAgger |"));
    ASSERT_NE(at, std::string::npos) << report;
    const double got = std::atof(report.c_str() + at + std::string("| Ensemble-DAgger | ").size());
    EXPECT_NEAR(got, want, 0.06 * want) << report.substr(at, 80);  // two significant figures of a ratio of rounded means
  }

  // Ensemble-DAgger's and Thrifty-DAgger's first updates train the same members on the same
  // demonstrations: whichever cell runs second loads them from the folder's cache and reports the
  // training's cost, and the two runs have the same threshold
  {
    auto first_update = [&](const std::string& method) {
      std::ifstream in(e.out + "/runs/" + method + "_seed0/queries.jsonl");
      for (std::string l; std::getline(in, l);)
        if (l.find("\"update_finished\"") != std::string::npos) return nlohmann::json::parse(l);
      return nlohmann::json();
    };
    const nlohmann::json t = first_update("thrifty"), en = first_update("ensemble");
    ASSERT_FALSE(t.is_null());
    ASSERT_FALSE(en.is_null());
    EXPECT_EQ(t.value("train_reused", false) + en.value("train_reused", false), 1) << t.dump() << "\n" << en.dump();
    // Thrifty-DAgger's training is the ensemble's and its critic's: the reused one reports the former
    EXPECT_GT(en.at("train_s").get<double>(), 0.0);
    EXPECT_LE(en.at("train_s").get<double>(), t.at("train_s").get<double>());
    EXPECT_EQ(t.at("threshold").get<double>(), en.at("threshold").get<double>());
    EXPECT_TRUE(fs::is_directory(e.out + "/runs/ensemble_cache"));
  }

  // `plot`: figures 4 and 5 from the runs' event logs
  PlotOptions p;
  p.dir = e.out;
  EXPECT_EQ(plot_runs(p).size(), 6u);
  std::ifstream wallclock(e.out + "/wallclock.csv");
  std::getline(wallclock, header);
  std::set<std::string> methods;
  while (std::getline(wallclock, line)) methods.insert(line.substr(0, line.find(',')));
  EXPECT_EQ(methods, (std::set<std::string>{"diff", "ensemble", "thrifty", "bc"}));
  // a run stopped right after its first update has no decision yet: it is still a method that asks,
  // drawn in figure 4, and only BC is not
  {
    const std::string log = e.out + "/runs/thrifty_seed0/queries.jsonl";
    std::ifstream in(log);
    std::string kept;
    for (std::string l; std::getline(in, l);) {
      kept += l + "\n";
      if (l.find("\"update_finished\"") != std::string::npos) break;
    }
    in.close();
    ASSERT_EQ(kept.find("\"decision\""), std::string::npos);
    const std::string full = read_text(log);
    write_text(log, kept);
    plot_runs(p);
    std::map<std::string, std::string> asks;
    std::ifstream w(e.out + "/wallclock.csv");
    std::getline(w, header);
    EXPECT_EQ(header.rfind("method,asks,iterations,", 0), 0u) << header;
    while (std::getline(w, line)) {
      const size_t a = line.find(','), b = line.find(',', a + 1);
      asks[line.substr(0, a)] = line.substr(a + 1, b - a - 1);
    }
    EXPECT_EQ(asks, (std::map<std::string, std::string>{{"diff", "yes"}, {"ensemble", "yes"}, {"thrifty", "yes"}, {"bc", "no"}}));
    write_text(log, full);
    plot_runs(p);
  }
  std::ifstream episode(e.out + "/episode.csv");
  std::getline(episode, header);
  std::set<std::string> rows_of;
  while (std::getline(episode, line)) rows_of.insert(line.substr(0, line.find(',')));
  EXPECT_EQ(rows_of, (std::set<std::string>{"diff", "ensemble", "thrifty"})) << "BC never decides: no row";
  const ui::Image fig5 = ui::read_png(e.out + "/figure5_episode.png");
  EXPECT_GT(fig5.width, 400);
  // a corrupt line (not the last) is refused with the file and line
  {
    const std::string log = e.out + "/runs/diff_seed0/queries.jsonl";
    const std::string text = [&] {
      std::ifstream f(log);
      std::stringstream ss;
      ss << f.rdbuf();
      return ss.str();
    }();
    std::ofstream(log) << "{not json\n" << text;
    try {
      plot_runs(p);
      ADD_FAILURE() << "a corrupt log was plotted";
    } catch (const Error& err) {
      EXPECT_NE(std::string(err.what()).find(log + ":1"), std::string::npos) << err.what();
    }
  }
  fs::remove_all(e.out);
}

// `plot`'s per-iteration table: each update's own cost, then the rollouts that followed it, up to the
// next update. A lone dagger folder's log, written by hand: two initial demonstrations (before any
// policy: in no iteration), update 1, two episodes (the robot alone succeeds in one; the gate asks in
// the other), update 2, one episode the robot runs into the time limit, and no third update yet.
TEST(DaggerNav2d, PlotTablesEveryIterationFromTheLog) {
  const std::string dir = temp_dir("plot_iterations");
  fs::create_directories(dir);
  const std::string log = R"({"event":"episode_start","episode":1,"step":0,"control":"expert_demo"}
{"event":"episode_end","episode":1,"step":30,"control":"expert_demo","success":true}
{"event":"episode_end","episode":2,"step":25,"control":"expert_demo","success":true}
{"event":"update_finished","episode":2,"step":0,"expert_demos":2,"pairs":40,"train_s":1.5,"threshold_s":0.5,"threshold_refined":3,"threshold":1.0}
{"event":"episode_start","episode":3,"step":0,"control":"robot"}
{"event":"decision","episode":3,"step":0,"score":0.5,"threshold":1.0,"inference_ms":100}
{"event":"decision","episode":3,"step":8,"score":0.5,"threshold":1.0,"inference_ms":200}
{"event":"episode_end","episode":3,"step":16,"control":"robot","success":true}
{"event":"episode_start","episode":4,"step":0,"control":"robot"}
{"event":"decision","episode":4,"step":0,"score":2.0,"threshold":1.0,"inference_ms":300}
{"event":"query","episode":4,"step":0}
{"event":"takeover","episode":4,"step":0,"control":"expert_query"}
{"event":"episode_end","episode":4,"step":20,"control":"expert_query","success":true}
{"event":"update_finished","episode":4,"step":0,"expert_demos":3,"pairs":60,"train_s":2.0,"threshold_s":0.25,"threshold":1.0}
{"event":"episode_start","episode":5,"step":0,"control":"robot"}
{"event":"decision","episode":5,"step":0,"score":0.5,"threshold":1.0,"inference_ms":50}
{"event":"timeout","episode":5,"step":40,"control":"robot"}
{"event":"takeover","episode":5,"step":40,"control":"expert_timeout"}
{"event":"episode_end","episode":5,"step":60,"control":"expert_timeout","success":true}
)";
  write_text(dir + "/queries.jsonl", log);
  PlotOptions p;
  p.dir = dir;
  const std::vector<std::string> written = plot_runs(p);
  EXPECT_NE(std::find(written.begin(), written.end(), dir + "/iterations.csv"), written.end());
  EXPECT_NE(std::find(written.begin(), written.end(), dir + "/figure_iterations.png"), written.end());
  auto rows = read_csv(dir + "/iterations.csv");
  ASSERT_EQ(rows.size(), 2u);
  auto& a = rows[0];
  EXPECT_EQ(a["update"], "1");
  EXPECT_EQ(a["demonstrations"], "2");
  EXPECT_EQ(a["pairs"], "40");
  EXPECT_DOUBLE_EQ(std::stod(a["train_s"]), 1.5);
  EXPECT_DOUBLE_EQ(std::stod(a["threshold_s"]), 0.5);
  EXPECT_EQ(a["threshold_refined"], "3");
  EXPECT_EQ(a["episodes"], "2");
  EXPECT_EQ(a["robot_successes"], "1") << "episode 4 succeeded, but by the expert";
  EXPECT_EQ(a["queries"], "1");
  EXPECT_EQ(a["timeouts"], "0");
  EXPECT_EQ(a["decisions"], "3");
  EXPECT_DOUBLE_EQ(std::stod(a["inference_s"]), 0.6);
  EXPECT_DOUBLE_EQ(std::stod(a["ms_per_decision"]), 200.0);
  EXPECT_EQ(a["complete"], "1");
  auto& b = rows[1];
  EXPECT_EQ(b["update"], "2");
  EXPECT_EQ(b["threshold_refined"], "") << "not logged: not a zero";
  EXPECT_EQ(b["episodes"], "1");
  EXPECT_EQ(b["robot_successes"], "0");
  EXPECT_EQ(b["timeouts"], "1");
  EXPECT_EQ(b["complete"], "0") << "no third update yet: its rollouts may not all be in";
  // figure 4 averages the complete iterations' decisions only: update 1's 0.6 s, not update 2's 0.05
  {
    auto w = read_csv(dir + "/wallclock.csv");
    ASSERT_EQ(w.size(), 1u);
    EXPECT_DOUBLE_EQ(std::stod(w[0]["inference_s"]), 0.6);
    EXPECT_DOUBLE_EQ(std::stod(w[0]["train_s"]), 1.75);
  }
  // the last update and the run's end: every iteration complete, the last without rollouts
  write_text(dir + "/queries.jsonl", log + R"({"event":"update_finished","episode":5,"step":0,"expert_demos":4,"pairs":80,"train_s":2.5,"threshold_s":0.5,"threshold":1.0}
{"event":"done","episode":5,"step":0}
)");
  plot_runs(p);
  rows = read_csv(dir + "/iterations.csv");
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[1]["complete"], "1");
  EXPECT_EQ(rows[2]["complete"], "1");
  EXPECT_EQ(rows[2]["decisions"], "0");
  EXPECT_EQ(rows[2]["ms_per_decision"], "");
  const ui::Image fig = ui::read_png(dir + "/figure_iterations.png");
  EXPECT_GT(fig.width, 3 * 400);
  EXPECT_GT(fig.height, 2 * 300) << "two rows of panels";
  fs::remove_all(dir);
}

// Figure 5 colours the expert's last span apart when the expert gave up (plugging: a toppled
// charger), and only then. A lone dagger folder's log, written by hand: the robot acts, asks at step
// 8, the expert takes over and ends the episode at step 20.
TEST(DaggerNav2d, PlotMarksAnExpertThatGaveUp) {
  const std::string dir = temp_dir("plot_gave_up");
  fs::create_directories(dir);
  auto brown_pixels = [&](bool gave_up) {
    write_text(dir + "/queries.jsonl",
               std::string(R"({"event":"episode_start","episode":1,"step":0,"control":"robot"}
{"event":"decision","episode":1,"step":0,"score":2.0,"threshold":1.0}
{"event":"decision","episode":1,"step":8,"score":3.0,"threshold":1.0}
{"event":"query","episode":1,"step":8}
{"event":"takeover","episode":1,"step":8,"control":"expert_query"}
{"event":"episode_end","episode":1,"step":20,"control":"expert_query")") +
                   (gave_up ? R"(,"gave_up":true})" : "}") + "\n");
    PlotOptions p;
    p.dir = dir;
    plot_runs(p);
    const ui::Image f = ui::read_png(dir + "/figure5_episode.png");
    int n = 0;
    for (size_t i = 0; i + 3 < f.rgba.size(); i += 4) n += f.rgba[i] == 120 && f.rgba[i + 1] == 72 && f.rgba[i + 2] == 40;
    return n;
  };
  EXPECT_GT(brown_pixels(true), 500) << "the span from step 8 to 20, and its legend swatch";
  EXPECT_EQ(brown_pixels(false), 0);
  fs::remove_all(dir);
}

// The cells `eval --jobs` hands to its child processes: every (method, seed, RQ) once, the ensemble
// methods' DAgger runs first; a malformed --cell is refused, saying what is wrong.
TEST(DaggerNav2d, EvalCellsCoverEveryMethodAndSeedLongestFirst) {
  const std::vector<std::string> methods{"diff", "ensemble", "thrifty", "bc"};
  const std::vector<EvalCell> cells = eval_cells(methods, 2);
  ASSERT_EQ(cells.size(), 14u);  // (3 methods x 2 + BC's 1) x 2 seeds
  EXPECT_EQ(cells[0].method, "thrifty");
  EXPECT_FALSE(cells[0].rq1);
  std::set<std::string> ids;
  for (const EvalCell& c : cells) {
    ids.insert(c.id());
    const EvalCell back = parse_eval_cell(c.id(), methods, 2);
    EXPECT_EQ(back.id(), c.id());
  }
  EXPECT_EQ(ids.size(), cells.size());
  EXPECT_EQ(ids.count("bc:1:rq1"), 0u);
  auto message = [&](const std::string& id) {
    try {
      parse_eval_cell(id, methods, 2);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  EXPECT_NE(message("bc:0:rq1").find("BC has no RQ1"), std::string::npos);
  EXPECT_NE(message("diff:2:rq2").find("seed '2'"), std::string::npos);
  EXPECT_NE(message("diff:x:rq2").find("seed 'x'"), std::string::npos);
  EXPECT_NE(message("dif:0:rq2").find("method 'dif'"), std::string::npos);
  EXPECT_NE(message("diff:0:rq3").find("'rq3'"), std::string::npos);
  EXPECT_NE(message("diff").find("METHOD:SEED"), std::string::npos);
}

TEST(DaggerNav2d, AStoppedEvaluationRerunsOnlyTheUnfinishedCells) {
  ExperimentConfig c;
  EvalOptions e = tiny_eval(c);
  e.methods = {"diff", "bc"};
  e.out = temp_dir("eval_cells");
  run_eval(c, e);
  const auto text = [](const std::string& path) {
    std::ifstream f(path);
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
  };
  const std::string rq1 = text(e.out + "/rq1.csv"), rq2 = text(e.out + "/rq2.csv");
  for (const char* cell : {"diff_seed0_rq1.json", "diff_seed0_rq2.json", "bc_seed0_rq2.json"})
    EXPECT_TRUE(fs::exists(e.out + "/cells/" + cell)) << cell;
  {
    // the RQ1 cell keeps its rollouts, one line each, and its counts are theirs
    const nlohmann::json cell = nlohmann::json::parse(text(e.out + "/cells/diff_seed0_rq1.json"));
    std::istringstream lines(text(e.out + "/cells/diff_seed0_rq1_rollouts.jsonl"));
    int rollouts = 0, successes = 0, tp = 0, fp = 0;
    for (std::string line; std::getline(lines, line);) {
      const RolloutResult r = rollout_from_json(line);
      ++rollouts;
      successes += r.success;
      tp += r.queried && !r.success;
      fp += r.queried && r.success;
      EXPECT_EQ(r.queried, r.first_query_step >= 0) << line;
      EXPECT_GT(r.steps, 0) << line;
    }
    EXPECT_EQ(rollouts, e.episodes);
    EXPECT_DOUBLE_EQ(cell.at("success").get<double>(), static_cast<double>(successes) / rollouts);
    EXPECT_EQ(cell.at("tp").get<int>(), tp);
    EXPECT_EQ(cell.at("fp").get<int>(), fp);
  }

  // as if stopped during BC's interactive learning: its cell reruns, Diff-DAgger's are read back
  fs::remove(e.out + "/cells/bc_seed0_rq2.json");
  const auto diff_cell_time = fs::last_write_time(e.out + "/cells/diff_seed0_rq2.json");
  run_eval(c, e);
  EXPECT_TRUE(fs::exists(e.out + "/cells/bc_seed0_rq2.json"));
  EXPECT_EQ(fs::last_write_time(e.out + "/cells/diff_seed0_rq2.json"), diff_cell_time) << "a finished cell ran again";
  EXPECT_EQ(text(e.out + "/rq1.csv"), rq1);
  EXPECT_EQ(text(e.out + "/rq2.csv"), rq2) << "the rerun cell gave another result";
  EXPECT_NE(text(e.out + "/report.md").find("cells finished by an earlier"), std::string::npos);

  // cells of another rollout count, or of another config, are refused naming the file
  e.episodes = 6;
  try {
    run_eval(c, e);
    ADD_FAILURE() << "cells of 4 rollouts were read as 6";
  } catch (const Error& err) {
    EXPECT_NE(std::string(err.what()).find("diff_seed0_rq1.json"), std::string::npos) << err.what();
  }
  e.episodes = 4;
  c.train.steps = 31;
  EXPECT_THROW(run_eval(c, e), Error);
  c.train.steps = 30;

  // one cell run on its own (`--cell`, as the report suggests) in a new folder prepares the folder;
  // in the folder of another config it is refused
  EvalOptions one = e;
  one.cell = "bc:0:rq2";
  const std::string fresh = temp_dir("eval_one_cell");
  one.out = fresh;
  run_eval(c, one);
  EXPECT_TRUE(fs::exists(one.out + "/config.json"));
  EXPECT_TRUE(fs::exists(one.out + "/cells/bc_seed0_rq2.json"));
  EXPECT_FALSE(fs::exists(one.out + "/cells/diff_seed0_rq2.json")) << "--cell ran more than its cell";
  one.out = e.out;
  c.train.steps = 31;
  try {
    run_eval(c, one);
    ADD_FAILURE() << "a cell ran in the folder of another config";
  } catch (const Error& err) {
    EXPECT_NE(std::string(err.what()).find("another config"), std::string::npos) << err.what();
  }
  fs::remove_all(e.out);
  fs::remove_all(fresh);
}

// Ensemble-DAgger's rule is Thrifty-DAgger's novelty half (the same members, threshold, acting member
// and rollout seeds), so Thrifty's RQ1 cell also writes Ensemble-DAgger's: it must be the cell that
// Ensemble-DAgger's own run gives, rollout by rollout.
TEST(DaggerNav2d, ThriftysRq1CellGivesTheEnsembleCellItsOwnRunGives) {
  ExperimentConfig c;
  EvalOptions e = tiny_eval(c);
  e.methods = {"ensemble", "thrifty"};
  c.method.alpha = 0.5;  // a low threshold, so that the rule asks in some rollouts
  EvalOptions own = e, given = e;
  own.cell = "ensemble:0:rq1";
  own.out = temp_dir("eval_ensemble_own");
  given.cell = "thrifty:0:rq1";
  given.out = temp_dir("eval_ensemble_given");
  run_eval(c, own);
  run_eval(c, given);
  const auto cell = [](const std::string& dir) { return nlohmann::json::parse(read_text(dir + "/cells/ensemble_seed0_rq1.json")); };
  const nlohmann::json a = cell(own.out), b = cell(given.out);
  for (const char* k : {"tp", "fp", "tn", "fn", "success", "threshold"}) EXPECT_EQ(a.at(k), b.at(k)) << k;
  EXPECT_FALSE(a.contains("from"));
  EXPECT_EQ(b.at("from"), "thrifty:0:rq1");
  const auto rollouts = [](const std::string& dir) {
    std::vector<RolloutResult> out;
    std::istringstream lines(read_text(dir + "/cells/ensemble_seed0_rq1_rollouts.jsonl"));
    for (std::string line; std::getline(lines, line);) out.push_back(rollout_from_json(line));
    return out;
  };
  const auto ra = rollouts(own.out), rb = rollouts(given.out);
  ASSERT_EQ(ra.size(), 4u);
  ASSERT_EQ(rb.size(), ra.size());
  int asked = 0;
  for (size_t i = 0; i < ra.size(); ++i) {
    EXPECT_EQ(ra[i].success, rb[i].success) << i;
    EXPECT_EQ(ra[i].queried, rb[i].queried) << i;
    EXPECT_EQ(ra[i].first_query_step, rb[i].first_query_step) << i;
    EXPECT_EQ(ra[i].steps, rb[i].steps) << i;
    EXPECT_EQ(ra[i].decisions, rb[i].decisions) << i;
    asked += ra[i].queried;
  }
  EXPECT_GT(asked, 0) << "the comparison never saw a query";
  // Thrifty's own cell counts its whole rule, which asks wherever its novelty half does
  const nlohmann::json t = nlohmann::json::parse(read_text(given.out + "/cells/thrifty_seed0_rq1.json"));
  EXPECT_GE(t.at("tp").get<int>() + t.at("fp").get<int>(), b.at("tp").get<int>() + b.at("fp").get<int>());
  // the cell records both thresholds its rule used: the spread's and the critic's gamma
  EXPECT_EQ(t.at("threshold"), b.at("threshold"));
  EXPECT_TRUE(t.contains("risk_threshold"));
  EXPECT_FALSE(a.contains("risk_threshold"));
  EXPECT_FALSE(b.contains("risk_threshold"));
  fs::remove_all(own.out);
  fs::remove_all(given.out);
}

// A quick `train` run on the toy: `steps` steps at batch 32 on 3 demonstrations, 3 rollouts at every
// curve point (`eval_every` steps) and at the end.
struct QuickTrain {
  ExperimentConfig config;
  TrainOptions options;
};
QuickTrain quick_train(int steps, int eval_every) {
  QuickTrain q{preset("nav2d"), {}};
  q.config.train.steps = steps;
  q.config.train.batch_size = 32;
  q.options.demos = 3;
  q.options.eval_episodes = 3;
  q.options.eval_every = eval_every;
  q.options.quiet = true;
  return q;
}

TEST(Train, BehaviourCloningWritesAPolicyACurveAndAnOutcomeBreakdown) {
  auto [c, o] = quick_train(30, 15);
  const std::string root = temp_dir("train");
  o.out = root + "/n3";
  const TrainRunResult r = run_train(c, o);
  EXPECT_EQ(r.demos, 3);
  ASSERT_EQ(r.curve.size(), 2u);  // after 15 and after 30 steps
  EXPECT_EQ(r.curve[0].first, 15);
  EXPECT_EQ(r.curve[1].first, 30);
  for (const char* f : {"policy.pt", "curve.csv", "losses.csv", "summary.json", "config.json"})
    EXPECT_TRUE(fs::exists(o.out + "/" + f)) << f;
  std::ifstream curve(o.out + "/curve.csv");
  std::string header, line;
  std::getline(curve, header);
  EXPECT_EQ(header, "step,success_rate,episodes,demos,outcomes");
  std::getline(curve, line);
  EXPECT_NE(line.find("\""), std::string::npos) << line;  // the outcome breakdown, quoted

  // the same policy, rolled out again from its checkpoint, succeeds as often
  TrainOptions again = o;
  again.init = o.out + "/policy.pt";
  again.out = root + "/n3_again";
  ExperimentConfig zero = c;
  zero.train.steps = 0;
  again.eval_every = 0;
  EXPECT_DOUBLE_EQ(run_train(zero, again).success, r.success);

  // a second demonstration count, then the learning curves over both
  o.demos = 5;
  o.out = root + "/n5";
  run_train(c, o);
  EXPECT_EQ(write_learning_curves(root), 3);
  for (const char* f : {"curves.csv", "success_vs_demos.png", "success_vs_steps.png"}) EXPECT_TRUE(fs::exists(root + "/" + f)) << f;

  // a data set with fewer successful episodes than asked for is an error naming the file
  TrainOptions bad = o;
  bad.data = root + "/missing.hdf5";
  EXPECT_THROW(run_train(c, bad), Error);
  fs::remove_all(root);
}

TEST(Train, AStoppedRunContinuesFromItsResumePoint) {
  auto [c, o] = quick_train(40, 20);
  const std::string root = temp_dir("resume");
  o.out = root + "/straight";
  const TrainRunResult straight = run_train(c, o);
  EXPECT_FALSE(fs::exists(o.out + "/resume")) << "a finished run keeps no resume point";

  o.out = root + "/stopped";
  o.save_every = 10;
  o.stop_after = 30;  // after the curve point at 20 and the resume point at 30
  EXPECT_TRUE(run_train(c, o).stopped);
  EXPECT_FALSE(fs::exists(o.out + "/summary.json"));
  EXPECT_TRUE(fs::exists(o.out + "/resume/trainer.pt"));
  o.stop_after = 0;
  const TrainRunResult resumed = run_train(c, o);
  EXPECT_FALSE(resumed.stopped);
  ASSERT_EQ(resumed.curve.size(), straight.curve.size());
  for (size_t i = 0; i < straight.curve.size(); ++i) {
    EXPECT_EQ(resumed.curve[i].first, straight.curve[i].first);
    EXPECT_DOUBLE_EQ(resumed.curve[i].second, straight.curve[i].second) << "step " << straight.curve[i].first;
  }
  EXPECT_NEAR(resumed.final_loss, straight.final_loss, 1e-4 * straight.final_loss);
  const auto lines = [](const std::string& path) {
    std::ifstream f(path);
    int n = 0;
    for (std::string line; std::getline(f, line);) ++n;
    return n;
  };
  EXPECT_EQ(lines(o.out + "/losses.csv"), 41);
  EXPECT_EQ(lines(o.out + "/curve.csv"), 3);  // header, step 20, step 40

  // a stopped run's folder refuses a run with another config
  o.out = root + "/other";
  o.stop_after = 10;
  run_train(c, o);
  ExperimentConfig longer = c;
  longer.train.steps = 50;
  o.stop_after = 0;
  try {
    run_train(longer, o);
    ADD_FAILURE() << "a different config resumed another run";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(o.out + "/config.json"), std::string::npos) << e.what();
  }
  fs::remove_all(root);
}

}  // namespace dd::app
