// The interactive-learning experiments behind `diffdagger dagger` and `diffdagger eval`.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/chunks.h"
#include "core/task_config.h"

namespace dd::app {

/// Whether the config file at `path` (config.json of a run folder) holds `config`: the same values,
/// with keys the file lacks (written before they existed) taken as the preset's. False when there is
/// no file; throws Error naming it when it is not JSON.
bool stored_config_matches(const std::string& path, const ExperimentConfig& config);

/// --task picks the preset of the same name (push: the two-expert variant); --config overrides it.
ExperimentConfig resolve_config(const std::string& task, const std::string& config_file);

/// One interactive-learning run with the scripted expert.
struct DaggerRunOptions {
  std::string method = "diff";   // diff | ensemble | thrifty | bc
  std::string out;               // folder: dataset.hdf5, checkpoints/, queries.jsonl, config.json
  bool quiet = false;            // no progress bars
  std::string label;             // starts the line per update (and on resuming); with it, quiet keeps those lines
  double lines_every_s = 300;    // quiet and labelled: a progress line at most this often, in training and between updates
  int stop_after_update = 0;     // stop after this update's resume point, as a stopped run would (0: run to the end)
};

struct DaggerRunResult {
  int episodes = 0, expert_demos = 0, interventions = 0, queries = 0, timeouts = 0, updates = 0;
  double train_s = 0, threshold_s = 0, inference_s = 0;  // summed over the run
  std::vector<double> iteration_train_s, iteration_threshold_s, iteration_inference_s;
  std::string dataset;
  bool stopped = false;          // stopped at stop_after_update; the same call continues the run
  int resumed_from_update = 0;   // the resume point this run continued from (0: a fresh run)
};

/// Policy updates continue from the previous weights, so a DAgger run's final policy has seen this
/// many training budgets; BC, trained once, gets the same number of gradient steps.
int bc_budget_factor(const DaggerConfig& dagger);

/// The training of an RQ1 policy: a whole training, like BC's (the per-update steps times the updates
/// when updates fine-tune; the epoch rule when they train from scratch), so that N_D alone sets how
/// good the policy is.
TrainConfig rq1_training(const ExperimentConfig& config);

/// "Diff-DAgger", "Ensemble-DAgger", "Thrifty-DAgger", "BC" (other names as they are), and each
/// method's colour in every figure.
std::string method_title(const std::string& method);
std::array<uint8_t, 3> method_color(const std::string& method);

/// `diffdagger plot DIR`: the paper's figures 4 and 5 from the logs of an `eval` folder's DAgger runs
/// (DIR/runs/METHOD_seedS/queries.jsonl) or of one `dagger` run folder, finished or not.
struct PlotOptions {
  std::string dir;
  int seed = 0;      // which seed's runs (an eval folder)
  int episode = 0;   // figure 5's episode (0: the first the robot acts in, N_i + 1)
};
/// Writes DIR/figure4_wallclock.png with wallclock.csv, DIR/figure_iterations.png with
/// iterations.csv (every update's cost and the rollouts up to the next), and DIR/figure5_episode.png with
/// episode.csv; returns the files written. Throws Error naming the folder or log that is missing or malformed.
std::vector<std::string> plot_runs(const PlotOptions& options);

/// `n` successful demonstrations of `task`'s expert in `mode`, for training without a session (RQ1,
/// `train` without a data set); episode e starts from seed * 1000033 + 777 + e.
std::vector<Episode> collect_demos(const std::string& task, const std::string& mode, int n, uint64_t seed);

/// eval's RQ1 policies for one seed: the first `members` members of the ensemble Ensemble-DAgger's
/// update would train on `demos` (member 0 is the policy Diff-DAgger's update would train, so one
/// training serves every method). Trains the members missing from `dir` (member_<i>.pt), one at a
/// time, each saved as it ends; cells in other processes share the work through lock files. Returns
/// the checkpoints' paths.
std::vector<std::string> rq1_policies(const ExperimentConfig& config, int members, const std::vector<Episode>& demos,
                                      const std::string& dir, const std::string& label);

/// Runs Algorithm 1 to N_f expert demonstrations; when `method_out` is given, the trained method is
/// kept there for evaluation. Throws dd::Error on bad input.
/// After every update but the last, the run leaves a resume point in out/resume (the method's state,
/// the session's, the data set and the query log as they stood); a stopped run called again with the
/// same config and method continues from the latest one and ends as an unstopped run would have. A
/// finished run removes it.
DaggerRunResult run_dagger(const ExperimentConfig& config, const DaggerRunOptions& options,
                           std::unique_ptr<Method>* method_out = nullptr);

/// `diffdagger train`: behaviour cloning on expert demonstrations, with a learning curve.
struct TrainOptions {
  std::string data;         // data set (robomimic layout) to train on; empty: collect with the config's expert
  int demos = 0;            // train on the first N successful expert episodes (0: all of the data set)
  std::string out;          // folder: policy.pt, curve.csv, losses.csv, summary.json
  int eval_episodes = 0;    // rollouts of the trained policy (0: none)
  int eval_every = 0;       // also roll out every this many steps, for a curve over training (0: at the end only)
  int curve_episodes = 0;   // rollouts at those intermediate points (0: eval_episodes)
  std::string init;         // a checkpoint to start from (with 0 steps: only roll it out)
  uint64_t eval_seed = kTrainEvalSeed;
  bool quiet = false;
  /// Also set Diff-DAgger's threshold over the training pairs (the preset's alpha and N_b):
  /// "" none, "screened" (the default method), "both" (screened and every pair at all rows, timed).
  std::string threshold;
  /// Leave a resume point (out/resume) every this many steps, besides after each curve point and at
  /// the end of training; the same command then continues a stopped run from its last one (0: only those).
  int save_every = 1000;
  int stop_after = 0;  // stop after this many steps, leaving a resume point (tests; 0: run to the end)
  static constexpr uint64_t kTrainEvalSeed = 950000;  // rollouts start here: never a demonstration's seed
};

struct TrainRunResult {
  int demos = 0, pairs = 0;
  double train_s = 0, eval_s = 0;
  double final_loss = 0;
  std::vector<std::pair<int, double>> curve;  // (training step, success rate)
  double success = NAN;                       // at the last step; NaN without rollouts
  nlohmann::json threshold;                   // --threshold's figures (null without it)
  bool stopped = false;                       // stopped at options.stop_after, with a resume point
};

/// Trains one policy with the config's network and budget (train.steps at train.batch_size) on the
/// demonstrations, saves it and rolls it out. Only successful episodes' expert steps are used. A run
/// stopped on the way (killed, or at options.stop_after) continues from its last resume point when
/// called again with the same config and folder; the folder of another config's stopped run is an Error.
TrainRunResult run_train(const ExperimentConfig& config, const TrainOptions& options);

/// Makes `config` run the network of `checkpoint` (its PolicyConfig, and its T_a for the session): an
/// imported policy may differ from the preset in every field but the task's observation and action
/// sizes, which are checked (an Error names the checkpoint). train --init and gui --policy use it.
void use_checkpoint_network(ExperimentConfig& config, const std::string& checkpoint);

/// `diffdagger curves DIR`: gathers the `train` runs in DIR's subfolders (summary.json, curve.csv) into
/// DIR/curves.csv, DIR/success_vs_demos.png (final success against demonstrations, one line per task
/// and expert) and DIR/success_vs_steps.png (success against training steps, one line per run).
/// Returns the number of runs found.
int write_learning_curves(const std::string& dir);

/// `diffdagger eval`: RQ1, RQ2, RQ3 for every method.
struct EvalOptions {
  std::string out = "out/eval";
  bool quick = false;
  int seeds = 1;
  int episodes = 100;   // rollouts per RQ1 / RQ2 measurement
  std::vector<std::string> methods = method_names();
  int jobs = 1;         // cells run at a time, each in a process of its own with one thread (1: in this process)
  std::string cell;     // "METHOD:SEED:rq1|rq2": run only this cell (what --jobs gives each child process)
  bool only_rq1 = false;  // run only the RQ1 cells (with --jobs as well), print them, and write no report
  bool report_only = false;  // run no cell: the report from the cells finished so far, the missing ones listed
  bool train_cache = true;   // ensembles' trainings memoised in OUT/runs/ensemble_cache (core/runtime.h)
  void apply_quick(ExperimentConfig& config);
};

/// One cell of an evaluation: RQ1 (a policy on N_D demonstrations), or RQ2 and RQ3 (a DAgger run to
/// N_f and its final policy's rollouts), of one method and seed. BC has only the second.
struct EvalCell {
  std::string method;
  int seed = 0;
  bool rq1 = false;
  std::string id() const;    // "METHOD:SEED:rq1|rq2"
  std::string stem() const;  // "METHOD_seedSEED_rq1|rq2": its file in cells/ (.json) and its log (.log)
};
/// Every cell of `methods` x `seeds`, the longest first (ensemble methods' DAgger runs train 5 members).
std::vector<EvalCell> eval_cells(const std::vector<std::string>& methods, int seeds);
/// Parses a cell id; an Error names what is wrong with it.
EvalCell parse_eval_cell(const std::string& id, const std::vector<std::string>& methods, int seeds);

/// The command line this process was started with (main() records it), for the child processes of
/// `eval --jobs`.
void set_command_line(int argc, char** argv);

/// Writes report.md, rq1.csv (and rq1_seeds.csv, rq1_outcomes.csv), rq2.csv, rq3.csv and the PNG plots to options.out.
void run_eval(const ExperimentConfig& config, const EvalOptions& options);

}  // namespace dd::app
