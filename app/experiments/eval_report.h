// The evaluation's report, internal to app/experiments/: its numbers per method over seeds, and the
// files made from them (rq1.csv, rq1_seeds.csv, rq1_outcomes.csv, rq2.csv, rq3.csv, the three plots, report.md).
#pragma once

#include <cmath>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "app/experiments.h"
#include "core/evaluation.h"

namespace dd::app {

/// One method's finished cells, one value per seed.
struct EvalRow {
  std::vector<double> success;                                     // RQ2, one value per seed
  std::vector<double> train, threshold, inference;                 // mean over a run's iterations
  std::vector<double> last_train, last_threshold, last_inference;  // the run's final iteration
  std::vector<int> rq2_seeds;                                      // the seeds of the values above
  std::vector<double> risk_data;  // Thrifty's risk data (collection and critic fit), one value per RQ1 cell
  /// Diff-DAgger's further gate rules (method.compare_scores), judged on the same rollouts: their
  /// RQ1 numbers, by rule.
  std::map<std::string, EvalRow> compared;
  /// Each seed's RQ1 cell as it is (report.md's table by seed, rq1_seeds.csv); thresholds NaN where
  /// the cell has none (a compared rule's entry; Thrifty-DAgger's gamma before cells recorded it).
  struct Rq1Seed {
    int seed = 0;
    int tp = 0, fp = 0, tn = 0, fn = 0;
    double tpr = NAN, tnr = NAN, f1 = NAN, acc = NAN, success = NAN, threshold = NAN, risk_threshold = NAN;
  };
  std::vector<Rq1Seed> rq1_by_seed;
  /// One field of each seed's record (&Rq1Seed::f1, ...), in the order the seeds were added.
  std::vector<double> rq1_values(double Rq1Seed::*field) const;
  std::vector<int> rq1_seeds() const;
  /// The seeds' counts summed; its rates and thresholds are NaN.
  Rq1Seed rq1_summed() const;
  /// The rollouts behind each seed's counts (cells/STEM_rollouts.jsonl), where on hand, each judged
  /// by this row's rule (a compared rule's row: its own verdicts and first query steps, the latter
  /// -1 where older files did not record them).
  std::map<int, std::vector<RolloutResult>> rq1_rollouts;

  /// One seed's RQ1 numbers from its cell (or a compared rule's entry in it); undefined rates are
  /// null there and NaN here.
  void add_rq1(const nlohmann::json& cell, double rollout_success, int seed);
  /// The rollouts of the seed's cell (added with add_rq1 before): kept where the main rule's counts
  /// from them are the cell's; each compared rule gets its verdicts where its counts also agree
  /// (rules named by the cell's "compare_rules", else its "compare" keys in order). Returns false,
  /// keeping nothing, where the rollouts are not the cell's.
  bool add_rq1_rollouts(const nlohmann::json& cell, const std::vector<RolloutResult>& rollouts, int seed);
  /// One seed's RQ2 and RQ3 numbers from its cell.
  void add_rq2(const nlohmann::json& cell, int seed);
};

/// Writes the CSVs, plots and report.md into o.out and prints the report. `seconds`: what this run
/// took; `skipped`: cells an earlier, stopped run had finished; `missing`: the ids of cells not
/// finished yet (eval --report), which makes the report a partial one.
void write_eval_report(const ExperimentConfig& config, const EvalOptions& o, const std::map<std::string, EvalRow>& rows,
                       double seconds, int skipped, const std::vector<std::string>& missing = {});

}  // namespace dd::app
