// The evaluation's report: Tables I and II, the wall-clock per iteration, their CSVs and plots, from
// the finished cells' numbers (app/experiments/eval.cpp runs the cells).
#include "app/experiments/eval_report.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "app/experiments/shared.h"
#include "core/method.h"
#include "core/progress.h"
#include "core/session.h"
#include "core/task_config.h"
#include "core/text_file.h"
#include "ui/plot.h"

namespace dd::app {
namespace {

// Mean and standard deviation over the finite values (NaN when there are none).
std::pair<double, double> finite_mean_std(const std::vector<double>& v) {
  std::vector<double> f;
  for (double x : v)
    if (std::isfinite(x)) f.push_back(x);
  return mean_std(f);
}

// "0.83", "0.83 +- 0.04" over seeds, or "n/a" where the value is undefined in every seed.
std::string pm(const std::vector<double>& v) {
  const auto [m, s] = finite_mean_std(v);
  if (!std::isfinite(m)) return "n/a";
  return v.size() > 1 ? fmt::format("{:.2f} +- {:.2f}", m, s) : fmt::format("{:.2f}", m);
}

// A p-value to two significant figures, small ones as a power of ten ("0.84", "0.003", "4e-60").
std::string p_value(double p) { return p >= 0.001 ? fmt::format("{:.2g}", p) : fmt::format("{:.0e}", p); }

std::string csv_num(double v) { return std::isfinite(v) ? fmt::format("{:.3f}", v) : "nan"; }

// "0.92 (seed 0), 0.88 (seed 1)": each seed's value.
std::string per_seed(const std::vector<double>& v, const std::vector<int>& seeds) {
  std::vector<std::string> parts;
  for (size_t i = 0; i < v.size() && i < seeds.size(); ++i) parts.push_back(fmt::format("{:.2f} (seed {})", v[i], seeds[i]));
  return parts.empty() ? "-" : fmt::format("{}", fmt::join(parts, ", "));
}

// "0, 1, 2", or "-" for none.
std::string seed_list(const std::vector<int>& seeds) { return seeds.empty() ? "-" : fmt::format("{}", fmt::join(seeds, ", ")); }

// A sum of means, or "n/a" when any is undefined (a method without finished cells).
std::string total(std::initializer_list<double> parts) {
  double t = 0;
  for (double x : parts) t += x;
  return std::isfinite(t) ? fmt::format("{:.2f}", t) : "n/a";
}

// The Mantel-Haenszel p of a row's seeds, each seed's counts a stratum.
double within_seeds_p(const EvalRow& r) {
  std::vector<AskFailTable> strata;
  for (const EvalRow::Rq1Seed& c : r.rq1_by_seed) strata.push_back({c.tp, c.fp, c.fn, c.tn});
  return mantel_haenszel_p(strata);
}

// Table I's and rq1.csv's rows of a method: its own rule, then the rules it was compared with.
std::vector<std::pair<std::string, const EvalRow*>> rq1_rows(const std::string& name, const EvalRow& row) {
  std::vector<std::pair<std::string, const EvalRow*>> out;
  if (row.rq1_by_seed.empty()) return out;
  out.emplace_back(name, &row);
  for (const auto& [rule, r] : row.compared) out.emplace_back(name + "@" + rule, &r);
  return out;
}

std::string rq1_title(const std::string& name, const std::string& row_name) {
  const size_t at = row_name.find('@');
  if (at == std::string::npos) return method_title(name);
  // Thrifty's compared rules are its own rule's halves; diff's are other ways to score its loss
  return fmt::format(name == "thrifty" ? "{}, {} alone" : "{}, scored {}", method_title(name), row_name.substr(at + 1));
}

// A rate, or "n/a" where undefined; a threshold, or "-" where the cell has none.
std::string rate_text(double v) { return std::isfinite(v) ? fmt::format("{:.2f}", v) : "n/a"; }
std::string threshold_text(double v) { return std::isfinite(v) ? fmt::format("{:.4g}", v) : "-"; }

// The rollouts of a row's seeds grouped by how they ended (Env::outcome()): successes first, then the
// most frequent; where the rule asked, and at which step it first asked.
struct OutcomeRow {
  std::string outcome;
  bool success = false;
  int rollouts = 0, asked = 0;
  std::vector<int> first_query_steps;  // of the asked rollouts whose step is recorded
};
std::vector<OutcomeRow> outcome_rows(const EvalRow& row) {
  std::map<std::pair<bool, std::string>, OutcomeRow> by;
  for (const auto& [seed, rollouts] : row.rq1_rollouts)
    for (const RolloutResult& r : rollouts) {
      const std::string outcome = !r.outcome.empty() ? r.outcome : r.success ? "success" : "failure";
      OutcomeRow& o = by[{r.success, outcome}];
      o.outcome = outcome, o.success = r.success;
      ++o.rollouts;
      if (r.queried) {
        ++o.asked;
        if (r.first_query_step >= 0) o.first_query_steps.push_back(r.first_query_step);
      }
    }
  std::vector<OutcomeRow> out;
  for (auto& [key, o] : by) out.push_back(std::move(o));
  std::stable_sort(out.begin(), out.end(), [](const OutcomeRow& a, const OutcomeRow& b) {
    return a.success != b.success ? a.success : a.rollouts > b.rollouts;
  });
  return out;
}

// The median of the steps, NaN for none.
double median(std::vector<int> v) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

std::string seed_keys(const std::map<int, std::vector<RolloutResult>>& m) {
  std::vector<int> seeds;
  for (const auto& [s, r] : m) seeds.push_back(s);
  return seed_list(seeds);
}

}  // namespace

void EvalRow::add_rq1(const nlohmann::json& cell, double rollout_success, int seed) {
  auto rate = [&](const char* k) { return cell.at(k).is_number() ? cell.at(k).get<double>() : NAN; };  // undefined: null
  auto number = [&](const char* k) { return cell.contains(k) && cell.at(k).is_number() ? cell.at(k).get<double>() : NAN; };
  Rq1Seed r;
  r.seed = seed;
  r.tp = cell.at("tp").get<int>(), r.fp = cell.at("fp").get<int>(), r.tn = cell.at("tn").get<int>(), r.fn = cell.at("fn").get<int>();
  r.tpr = rate("tpr"), r.tnr = rate("tnr"), r.f1 = rate("f1"), r.acc = rate("acc"), r.success = rollout_success;
  r.threshold = number("threshold"), r.risk_threshold = number("risk_threshold");
  rq1_by_seed.push_back(r);
  if (cell.contains("compare"))  // method.compare_scores: the other rules judged on the same rollouts
    for (const auto& [rule, p] : cell["compare"].items()) compared[rule].add_rq1(p, rollout_success, seed);
}

std::vector<double> EvalRow::rq1_values(double Rq1Seed::*field) const {
  std::vector<double> out;
  for (const Rq1Seed& c : rq1_by_seed) out.push_back(c.*field);
  return out;
}

std::vector<int> EvalRow::rq1_seeds() const {
  std::vector<int> out;
  for (const Rq1Seed& c : rq1_by_seed) out.push_back(c.seed);
  return out;
}

EvalRow::Rq1Seed EvalRow::rq1_summed() const {
  Rq1Seed sum;
  for (const Rq1Seed& c : rq1_by_seed) sum.tp += c.tp, sum.fp += c.fp, sum.tn += c.tn, sum.fn += c.fn;
  return sum;
}

bool EvalRow::add_rq1_rollouts(const nlohmann::json& cell, const std::vector<RolloutResult>& rollouts, int seed) {
  auto same_counts = [](const FailurePrediction& p, const nlohmann::json& c) {
    return p.tp == c.at("tp").get<int>() && p.fp == c.at("fp").get<int>() && p.tn == c.at("tn").get<int>() && p.fn == c.at("fn").get<int>();
  };
  if (rollouts.empty() || !same_counts(failure_prediction(rollouts), cell)) return false;
  rq1_rollouts[seed] = rollouts;
  if (!cell.contains("compare")) return true;
  std::vector<std::string> names;  // in the order of each rollout's compare_queried
  if (cell.contains("compare_rules"))
    names = cell.at("compare_rules").get<std::vector<std::string>>();
  else
    for (const auto& [rule, p] : cell.at("compare").items()) names.push_back(rule);  // JSON's order: checked by the counts below
  const bool recorded = std::all_of(rollouts.begin(), rollouts.end(), [&](const RolloutResult& r) { return r.compare_queried.size() == names.size(); });
  for (size_t i = 0; recorded && i < names.size(); ++i) {
    if (!cell.at("compare").contains(names[i]) || !compared.count(names[i])) continue;
    std::vector<RolloutResult> judged = judged_by(rollouts, i);
    if (same_counts(failure_prediction(judged), cell.at("compare").at(names[i])))
      compared[names[i]].rq1_rollouts[seed] = std::move(judged);
  }
  return true;
}

void EvalRow::add_rq2(const nlohmann::json& cell, int seed) {
  success.push_back(cell.at("success").get<double>());
  train.push_back(cell.at("train_s").get<double>());
  threshold.push_back(cell.at("threshold_s").get<double>());
  inference.push_back(cell.at("inference_s").get<double>());
  last_train.push_back(cell.at("last_train_s").get<double>());
  last_threshold.push_back(cell.at("last_threshold_s").get<double>());
  last_inference.push_back(cell.at("last_inference_s").get<double>());
  rq2_seeds.push_back(seed);
}

void write_eval_report(const ExperimentConfig& config, const EvalOptions& o, const std::map<std::string, EvalRow>& rows,
                       double seconds, int skipped, const std::vector<std::string>& missing) {
  const DaggerConfig& d = config.dagger;
  const bool bc_scaled = !config.train.from_scratch;
  // CSV files: the columns the issue names first, spreads and counts after them. "nan": undefined
  // (TPR with no failed rollout, TNR with no successful one).
  std::string rq1 = "method,tpr,tnr,f1,acc,tpr_std,tnr_std,f1_std,acc_std,tp,fp,tn,fn,success_rate,seeds,episodes,fisher_p,cmh_p\n";
  std::string rq2 = "method,success_rate,n,success_rate_std,seeds\n";
  std::string rq3 =
      "method,train_s,threshold_s,inference_s,total_s,last_train_s,last_threshold_s,last_inference_s,last_total_s,risk_data_s,"
      "train_s_std,threshold_s_std,inference_s_std,seeds\n";
  for (const std::string& name : o.methods) {
    for (const auto& [row_name, rp] : rq1_rows(name, rows.at(name))) {
      const EvalRow& r = *rp;
      const auto tpr = finite_mean_std(r.rq1_values(&EvalRow::Rq1Seed::tpr)), tnr = finite_mean_std(r.rq1_values(&EvalRow::Rq1Seed::tnr)),
                 f1 = finite_mean_std(r.rq1_values(&EvalRow::Rq1Seed::f1)), acc = finite_mean_std(r.rq1_values(&EvalRow::Rq1Seed::acc));
      const EvalRow::Rq1Seed c = r.rq1_summed();
      rq1 += fmt::format("{},{},{},{},{},{},{},{},{},{},{},{},{},{:.3f},{},{},{:.3g},{:.3g}\n", row_name, csv_num(tpr.first), csv_num(tnr.first),
                         csv_num(f1.first), csv_num(acc.first), csv_num(tpr.second), csv_num(tnr.second), csv_num(f1.second),
                         csv_num(acc.second), c.tp, c.fp, c.tn, c.fn, mean(r.rq1_values(&EvalRow::Rq1Seed::success)),
                         r.rq1_by_seed.size(), o.episodes, fisher_exact_p(c.tp, c.fp, c.fn, c.tn), within_seeds_p(r));
    }
    const EvalRow& r = rows.at(name);
    rq2 += fmt::format("{},{},{},{},{}\n", name, csv_num(mean_std(r.success).first), o.episodes * r.success.size(),
                       csv_num(mean_std(r.success).second), r.success.size());
    const double risk = r.risk_data.empty() ? 0.0 : mean(r.risk_data);
    rq3 += fmt::format("{},{},{},{},{},{},{},{},{},{:.3f},{},{},{},{}\n", name, csv_num(mean(r.train)), csv_num(mean(r.threshold)),
                       csv_num(mean(r.inference)), csv_num(mean(r.train) + mean(r.threshold) + mean(r.inference)),
                       csv_num(mean(r.last_train)), csv_num(mean(r.last_threshold)), csv_num(mean(r.last_inference)),
                       csv_num(mean(r.last_train) + mean(r.last_threshold) + mean(r.last_inference)), risk,
                       csv_num(mean_std(r.train).second), csv_num(mean_std(r.threshold).second), csv_num(mean_std(r.inference).second),
                       r.train.size());
  }
  // Each seed's cell, and the rollouts behind the counts by how they ended.
  std::string rq1_seeds = "method,seed,success_rate,tpr,tnr,f1,acc,tp,fp,tn,fn,fisher_p,threshold,risk_threshold\n";
  std::string rq1_outcomes = "method,outcome,success,rollouts,asked,median_first_query_step,seeds\n";
  for (const std::string& name : o.methods)
    for (const auto& [row_name, rp] : rq1_rows(name, rows.at(name))) {
      for (const EvalRow::Rq1Seed& c : rp->rq1_by_seed)
        rq1_seeds += fmt::format("{},{},{:.3f},{},{},{},{},{},{},{},{},{:.3g},{},{}\n", row_name, c.seed, c.success, csv_num(c.tpr), csv_num(c.tnr),
                                 csv_num(c.f1), csv_num(c.acc), c.tp, c.fp, c.tn, c.fn, fisher_exact_p(c.tp, c.fp, c.fn, c.tn),
                                 std::isfinite(c.threshold) ? fmt::format("{:.6g}", c.threshold) : "nan",
                                 std::isfinite(c.risk_threshold) ? fmt::format("{:.6g}", c.risk_threshold) : "nan");
      for (const OutcomeRow& r : outcome_rows(*rp))
        rq1_outcomes += fmt::format("{},\"{}\",{},{},{},{},{}\n", row_name, r.outcome, r.success ? 1 : 0, r.rollouts, r.asked,
                                    csv_num(median(r.first_query_steps)), rp->rq1_rollouts.size());
    }
  write_text(o.out + "/rq1_seeds.csv", rq1_seeds);
  write_text(o.out + "/rq1_outcomes.csv", rq1_outcomes);
  write_text(o.out + "/rq1.csv", rq1);
  write_text(o.out + "/rq2.csv", rq2);
  write_text(o.out + "/rq3.csv", rq3);

  namespace fs = std::filesystem;
  // Plots: one per RQ that has a finished cell (a partial report may have none for RQ2 and RQ3).
  // A partial report's bars can be over different seeds (one method's cells finish before another's):
  // each says under its name over how many, so that a reader does not compare 3 seeds with 1 unawares.
  const bool partial = !missing.empty();
  auto bars = [&](const std::string& title, const std::string& label, auto value, auto seeds, bool gated_only) {
    ui::BarPanel p;
    p.title = title;
    p.y_label = label;
    p.width = 480;
    for (const std::string& name : o.methods) {
      if (gated_only && !method_info(name).gated) continue;
      const auto [m, sd] = value(rows.at(name));
      if (!std::isfinite(m)) continue;  // no finished cell (a partial report)
      const size_t n = seeds(rows.at(name));
      p.categories.push_back(partial ? fmt::format("{} ({} seed{})", method_title(name), n, n == 1 ? "" : "s") : method_title(name));
      p.values.push_back(m);
      p.errors.push_back(sd);
      p.colors.push_back(method_color(name));
    }
    return p;
  };
  const std::string caption =
      partial ? fmt::format("task {} (preset {}): partial, each bar over the seeds finished (named under it; up to {}), {} rollouts each", config.task,
                            config.preset, o.seeds, o.episodes)
      : o.seeds > 1 ? fmt::format("task {} (preset {}): mean +- sample std over {} seeds, {} rollouts each", config.task, config.preset, o.seeds, o.episodes)
                  : fmt::format("task {} (preset {}): one seed, {} rollouts each", config.task, config.preset, o.episodes);
  std::vector<std::string> plots;
  auto plot = [&](const std::string& file, const std::vector<ui::BarPanel>& panels) {
    if (panels.front().values.empty()) {
      fs::remove(o.out + "/" + file);  // an earlier report's, if any, would be of nothing now either
      return;
    }
    std::vector<ui::Image> images;
    for (const ui::BarPanel& p : panels) images.push_back(ui::draw_bars(p));
    ui::write_png(o.out + "/" + file, ui::hstack(images, caption));
    plots.push_back("`" + file + "`");
  };
  const auto rq1_n = [](const EvalRow& r) { return r.rq1_by_seed.size(); };
  const auto rq2_n = [](const EvalRow& r) { return r.success.size(); };
  const auto rq3_n = [](const EvalRow& r) { return r.last_train.size(); };
  plot("rq1_failure_prediction.png",
       {bars("RQ1: F1 of queries vs failures", "F1", [](const EvalRow& r) { return finite_mean_std(r.rq1_values(&EvalRow::Rq1Seed::f1)); }, rq1_n, true),
        bars("RQ1: accuracy", "accuracy", [](const EvalRow& r) { return finite_mean_std(r.rq1_values(&EvalRow::Rq1Seed::acc)); }, rq1_n, true)});
  plot("rq2_success.png", {bars(fmt::format("RQ2: success after N_f = {}", d.final_demos), "success rate",
                                [](const EvalRow& r) { return mean_std(r.success); }, rq2_n, false)});
  plot("rq3_wallclock.png",
       {bars("RQ3: training, final iteration", "seconds", [](const EvalRow& r) { return mean_std(r.last_train); }, rq3_n, false),
        bars("RQ3: threshold setting, final", "seconds", [](const EvalRow& r) { return mean_std(r.last_threshold); }, rq3_n, false),
        bars("RQ3: inference, final iteration", "seconds", [](const EvalRow& r) { return mean_std(r.last_inference); }, rq3_n, false)});

  // Report.
  const std::string budget =
      config.train.from_scratch
          ? fmt::format("every update retrains from scratch for {} epochs (at most {} steps)", config.train.epochs, config.train.max_steps)
          : fmt::format("{} training steps per update, continuing from the previous weights", config.train.steps);
  std::string md = fmt::format("# Evaluation on {} (preset {}, expert {}){}\n\n{}{} seed(s), {} rollouts per measurement{}{}. "
                               "Schedule: N_i {}, N_f {}, N_d {}, alpha {}, K {} (the gate scores every {}), T_L {}, T_p {}, T_a {}; {}. "
                               "Thresholds over {} training pairs; the loss is scored with the {} weights, in {} space.\n\n",
                               config.task, config.preset, config.expert, partial ? ", in progress" : "",
                               partial ? fmt::format("**Partial report** (`eval --report`): {} cells are not finished (listed at the end); "
                                                     "each row is over the seeds it has, named in its row. ",
                                                     missing.size())
                                       : "",
                               o.seeds, o.episodes, o.seeds > 1 ? "; +- is the sample standard deviation over seeds" : "",
                               o.quick ? " (quick run: tiny budgets and 3-member ensembles, a smoke test; read with care)" : "",
                               d.initial_demos, d.final_demos, d.demos_per_update, config.method.alpha, d.patience, to_string(d.gate_every),
                               d.time_limit, config.policy.horizon, config.policy.action_steps, budget,
                               config.method.calibration_pairs > 0 ? fmt::format("at most {}", config.method.calibration_pairs) : "all",
                               config.method.score_raw_weights ? "raw training" : "EMA",
                               config.method.score_space == "target" ? "the training target's" : config.method.score_space);
  md += "## Deviations from the paper's protocol\n\n";
  for (const std::string& line : paper_deviations(config)) md += "- " + line + "\n";
  md += "\n";
  md += fmt::format("## Table I: failure prediction (RQ1)\n\nPolicies trained on N_D = {} demonstrations, rolled out without intervention. "
                    "They are trained like BC ({}). "
                    "Positive = the rule would have asked; actual positive = the episode failed. TP, FP, TN, FN are summed over seeds; "
                    "n/a: undefined (no failed rollout for TPR, no successful one for TNR). p: two-sided Fisher exact test of asking "
                    "against failing on the counts (summed over seeds; no test of direction, so read it beside TPR and 1 - TNR): "
                    "small where the rule's positives go with failures more than chance would have it. p within seeds: the Cochran-Mantel-Haenszel "
                    "test of the same with each seed a stratum, which summing cannot fool (seeds whose policies fail at different rates "
                    "can make an association in the sums that no seed has). Ensemble-DAgger and Thrifty-DAgger act with "
                    "the member trained on all the demonstrations; the other members are bootstrapped. The three methods' policies are "
                    "one ensemble per seed, trained once: Diff-DAgger's is its member 0, the very policy its own update would train "
                    "(same initial weights, data and minibatches), so the methods differ only in the query rule.\n\n"
                    "| Task | N_D | Method | TPR | TNR | F1 | Acc | TP | FP | TN | FN | p | p within seeds | rollout success | which seeds |\n"
                    "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
                    config.rq1_demos,
                    config.train.from_scratch ? "the epoch rule" : fmt::format("{} steps", rq1_training(config).steps));
  for (const std::string& name : o.methods)
    for (const auto& [row_name, rp] : rq1_rows(name, rows.at(name))) {
      const EvalRow& r = *rp;
      const EvalRow::Rq1Seed c = r.rq1_summed();
      auto values = [&](double EvalRow::Rq1Seed::*field) { return pm(r.rq1_values(field)); };
      md += fmt::format("| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n", config.task, config.rq1_demos,
                        rq1_title(name, row_name), values(&EvalRow::Rq1Seed::tpr), values(&EvalRow::Rq1Seed::tnr),
                        values(&EvalRow::Rq1Seed::f1), values(&EvalRow::Rq1Seed::acc), c.tp, c.fp, c.tn, c.fn,
                        p_value(fisher_exact_p(c.tp, c.fp, c.fn, c.tn)), p_value(within_seeds_p(r)),
                        values(&EvalRow::Rq1Seed::success), seed_list(r.rq1_seeds()));
    }
  if (std::find(o.methods.begin(), o.methods.end(), "thrifty") != o.methods.end())
    md += "\nRows \"novelty alone\" and \"risk alone\" judge Thrifty-DAgger's rollouts by one half of its rule (the "
          "ensemble's spread above its threshold; the critic's success estimate below gamma), K in a row, so that they show "
          "which half asked; cells run before the halves were recorded count in the rule's row only.\n";
  if (!config.method.compare_scores.empty())
    md += fmt::format("\nRows \"scored R\" judge the same rollouts by another gate rule (method.compare_scores; R is the score space, "
                      "and @K keeps the diffusion timesteps below K), each with its own alpha-quantile threshold over the same "
                      "training pairs; the method acted on its main rule (score space {}).\n",
                      config.method.score_space);
  {
    std::string lines;
    for (const std::string& name : o.methods)
      for (const auto& [row_name, rp] : rq1_rows(name, rows.at(name)))
        for (const EvalRow::Rq1Seed& c : rp->rq1_by_seed)
          lines += fmt::format("| {} | {} | {:.2f} | {} | {} | {} | {} | {} / {} / {} / {} | {} | {} | {} |\n", rq1_title(name, row_name), c.seed,
                               c.success, rate_text(c.tpr), rate_text(c.tnr), rate_text(c.f1), rate_text(c.acc), c.tp, c.fp, c.tn, c.fn,
                               p_value(fisher_exact_p(c.tp, c.fp, c.fn, c.tn)), threshold_text(c.threshold), threshold_text(c.risk_threshold));
    if (!lines.empty())
      md += "\n### Table I by seed\n\nEach seed's cell (`rq1_seeds.csv`), p its own Fisher test. Threshold: the rule's, as the "
            "rollouts saw it (the loss quantile for Diff-DAgger, the spread's for the ensembles); gamma: Thrifty-DAgger's risk "
            "threshold on the critic's success estimate; - where the cell did not record it.\n\n"
            "| Method | seed | rollout success | TPR | TNR | F1 | Acc | TP / FP / TN / FN | p | threshold | gamma |\n"
            "|---|---|---|---|---|---|---|---|---|---|---|\n" + lines;
  }
  {
    std::string lines;
    for (const std::string& name : o.methods)
      for (const auto& [row_name, rp] : rq1_rows(name, rows.at(name)))
        for (const OutcomeRow& r : outcome_rows(*rp)) {
          const double m = median(r.first_query_steps);
          lines += fmt::format("| {} | {}{} | {} | {} | {} | {} |\n", rq1_title(name, row_name), r.outcome, r.success && r.outcome != "success" ? " (success)" : "",
                               r.rollouts, r.asked, std::isfinite(m) ? fmt::format("{:g}", m) : "-", seed_keys(rp->rq1_rollouts));
        }
    if (!lines.empty())
      md += "\n### How the rollouts ended, and where each rule asked\n\nFrom the rollouts behind the counts "
            "(`cells/METHOD_seedS_rq1_rollouts.jsonl`, where a cell has them; `rq1_outcomes.csv`), summed over the seeds named: "
            "how many rollouts ended each way, in how many the rule asked, and the median environment step of its first "
            "query there (- where it never asked, or the file did not record the step).\n\n"
            "| Method | how the rollout ended | rollouts | the rule asked | first query, median step | seeds |\n"
            "|---|---|---|---|---|---|\n" + lines;
  }
  md += fmt::format("\n## Table II: task performance (RQ2)\n\nSuccess rate of the final policy after interactive learning to N_f = {} "
                    "expert demonstrations (successful ones: an episode the expert failed is recorded but not trained on). {}\n\n"
                    "| Task | Method | Success rate | per seed |\n|---|---|---|---|\n",
                    d.final_demos,
                    bc_scaled ? fmt::format("BC: {} demonstrations, trained once with {}x the per-update budget, the gradient steps a DAgger "
                                            "run spends over its {} updates, since updates continue from the previous weights.",
                                            d.final_demos, bc_budget_factor(d), bc_budget_factor(d))
                              : fmt::format("BC: {} demonstrations, trained once by the same epoch rule as every update.", d.final_demos));
  for (const std::string& name : o.methods) {
    const EvalRow& r = rows.at(name);
    md += fmt::format("| {} | {} | {} | {} |\n", config.task, method_title(name), pm(r.success), per_seed(r.success, r.rq2_seeds));
  }
  md += "\n## Wall-clock per DAgger iteration (RQ3)\n\nThe final iteration (the paper's figure 4) and, in brackets, the mean over "
        "a run's iterations. Thrifty's risk data: the robot rollouts and critic refit its RQ1 policy needed before it could "
        "judge risk.\n\n| Method | training [s] | threshold setting [s] | inference [s] | total [s] | risk data [s] |\n"
        "|---|---|---|---|---|---|\n";
  for (const std::string& name : o.methods) {
    const EvalRow& r = rows.at(name);
    md += fmt::format("| {} | {} ({}) | {} ({}) | {} ({}) | {} ({}) | {} |\n", method_title(name), pm(r.last_train), pm(r.train),
                      pm(r.last_threshold), pm(r.threshold), pm(r.last_inference), pm(r.inference),
                      total({mean(r.last_train), mean(r.last_threshold), mean(r.last_inference)}),
                      total({mean(r.train), mean(r.threshold), mean(r.inference)}), r.risk_data.empty() ? "-" : pm(r.risk_data));
  }
  // The paper's RQ3 claim is a set of ratios against Diff-DAgger (Ensemble-DAgger: 5.1x the training,
  // 48x the threshold setting, 3.8x the inference, 7.8x in total); ours, from the means per iteration.
  const auto diff_row = rows.find("diff");
  if (diff_row != rows.end() && !diff_row->second.train.empty()) {
    const EvalRow& dr = diff_row->second;
    auto ratio = [](double a, double b) { return b > 0 && std::isfinite(a) ? fmt::format("{:.2g}x", a / b) : std::string("n/a"); };
    std::string lines;
    for (const std::string& name : o.methods) {
      const EvalRow& r = rows.at(name);
      if (name == "diff" || name == "bc" || r.train.empty()) continue;
      lines += fmt::format("| {} | {} | {} | {} | {} |\n", method_title(name), ratio(mean(r.train), mean(dr.train)),
                           ratio(mean(r.threshold), mean(dr.threshold)), ratio(mean(r.inference), mean(dr.inference)),
                           ratio(mean(r.train) + mean(r.threshold) + mean(r.inference), mean(dr.train) + mean(dr.threshold) + mean(dr.inference)));
    }
    if (!lines.empty())
      md += "\nAgainst Diff-DAgger: each method's mean seconds per iteration over Diff-DAgger's (the bracketed means above, over "
            "the seeds each has). The paper's figure 4 has Ensemble-DAgger at 5.1x the training, 48x the threshold setting, "
            "3.8x the inference and 7.8x in total.\n\n| Method / Diff-DAgger | training | threshold setting | inference | total |\n"
            "|---|---|---|---|---|\n" + lines;
  }
  md += fmt::format("\nInference is the time spent deciding during the robot's rollouts between two updates. "
                    "Plots: {}. "
                    "Each run's data set, checkpoints and query log are under `runs/`, each finished cell's numbers under `cells/`. "
                    "{}.\n",
                    plots.empty() ? std::string("none yet (no finished cell)") : fmt::format("{}", fmt::join(plots, ", ")),
                    partial || o.report_only ? std::string("Written by `eval --report` from the finished cells")
                            : fmt::format("Took {}{}", format_duration(seconds),
                                          skipped > 0 ? fmt::format(" (and {} cells finished by an earlier, stopped run)", skipped) : ""));
  if (partial)
    md += fmt::format("\n## Cells not finished\n\n{}\n\nThe same `eval` command without `--report` runs them (`--cell ID` runs one).\n",
                      fmt::format("{}", fmt::join(missing, ", ")));
  write_text(o.out + "/report.md", md);
  fmt::print("{}", md);
}

}  // namespace dd::app
