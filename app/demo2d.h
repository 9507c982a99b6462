// The 2-D multimodality demo (the paper's figure 2): does the ensemble mistake a multi-modal decision
// point for uncertainty, while the diffusion loss rises only out of distribution?
//
// Collects mixed clockwise / counter-clockwise expert demonstrations on the nav2d toy, trains one
// diffusion policy and a 5-member bootstrapped ensemble of the same architecture, then over `runs`
// runs probes one state in each region (in-distribution uni-modal, in-distribution multi-modal,
// out-of-distribution) and records the ensemble's action standard deviation and the policy's expected
// diffusion loss of the chunk it generates there. Writes to the output folder:
//   fig2_regions.csv   region, metric, mean, std, n
//   fig2_regions.png   the two bar plots of figure 2b
//   loss_field.png     diffusion loss and ensemble std over the plane, demonstration paths on top
//   summary.md         whether the paper's qualitative claim holds on this run, and by how much
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace dd::app {

struct Demo2dOptions {
  std::string out = "out/demo2d";
  bool quick = false;        // a reduced run for tests (apply_quick() sets the sizes below)
  uint64_t seed = 0;
  std::string preset = "tiny";
  int demos = 100;           // expert demonstrations (mixed modes)
  int train_steps = 1500;    // per policy
  int batch_size = 128;
  int members = 5;           // ensemble size
  int runs = 100;            // probes per region
  int grid = 40;             // field resolution (cells per side)
  int loss_samples = 512;    // N_b for the region probes and the threshold
  int field_loss_samples = 128;  // N_b for the field (cheaper; it is a picture)
  double alpha = 0.99;       // quantile for the query thresholds reported in the summary
  std::string prediction = "v_prediction";  // the diffusion objective: v_prediction, epsilon, sample
  int seeds = 1;             // run_demo2d_seeds: seeds seed, seed + 1, ... (--full: 3)

  /// Shrinks everything for a run of about a minute.
  void apply_quick();
};

/// One row of fig2_regions.csv.
struct RegionStat {
  std::string region;  // id_um, id_mm, ood
  std::string metric;  // ensemble_std, diffusion_loss
  double mean = 0, std = 0;
  int n = 0;
};

struct Demo2dResult {
  std::vector<RegionStat> stats;
  bool claim_holds = false;
  /// "measure/group" -> the mean over the group's probes. Measures: ensemble_std, loss_<space> (the
  /// expected loss scored in that space: target, epsilon, v, sample); groups: id_um, id_mm, ood,
  /// along_<steps>.
  std::map<std::string, double> means;
  std::vector<std::string> files;  // everything written
};

/// Runs the demo for options.seed into options.out; throws dd::Error on failure (naming the file when
/// writing fails).
Demo2dResult run_demo2d(const Demo2dOptions& options);

/// With options.seeds == 1, run_demo2d. With more, runs each seed into out/seed_<s> and writes, in
/// out, summary.md and fig2_seeds.csv: each score's ratios per seed, their mean and spread, and in how
/// many seeds the paper's claim holds. Returns each seed's result. A seed whose folder holds a finished
/// run (summary.md) is read back from its fig2_along_paths.csv instead of run again, so a stopped run
/// continues where it stopped.
std::vector<Demo2dResult> run_demo2d_seeds(const Demo2dOptions& options);

/// The means a finished seed's fig2_along_paths.csv holds (every group's ensemble_std and loss_<space>
/// but the target space's), as Demo2dResult::means; an Error names the file and line of a malformed row.
Demo2dResult read_demo2d_means(const std::string& path);

}  // namespace dd::app
