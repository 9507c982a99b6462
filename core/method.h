// The interactive-learning methods behind one interface: a learner plus its query rule.
//
//   diff      one diffusion policy; score = expected diffusion loss of the generated chunk
//   ensemble  5 bootstrapped policies; score = variance of their chunks
//   thrifty   ensemble novelty (variance) or risk (learned Q below gamma)
//   bc        one policy, never asks
//
// update() trains on all expert data and then sets the threshold (the alpha-quantile of the score
// over the training pairs); decide() generates a chunk and says whether it violates the threshold.
// The patience K lives in the session's QueryGate, the same for every method.
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/chunks.h"
#include "core/config.h"
#include "core/critic.h"
#include "core/dataset.h"
#include "core/progress.h"

#include <nlohmann/json_fwd.hpp>

namespace dd {

class DiffusionPolicy;

/// Settings shared by the query rules.
struct MethodConfig {
  double alpha = 0.99;           // threshold quantile
  int members = 5;               // ensemble size (ensemble, thrifty)
  int loss_samples = 512;        // N_b (diff)
  int calibration_pairs = 0;     // threshold over at most this many training pairs (0: all, the paper's rule)
  bool screen_threshold = true;  // diff: screen the pairs with 1/8 of the rows first (the same quantile, DiffusionPolicy::loss_quantile)
  bool screen_gate = true;       // diff: score each decision's chunk with 1/8 of the rows first, more only near the threshold (the same verdict, DiffusionPolicy::decide_screened)
  bool score_raw_weights = false;  // diff: score the loss with the raw training weights instead of the EMA
  int score_timesteps = 0;  // diff: the loss draws t from [0, this) only; 0: every timestep (the paper's)
  std::string score_space = "target";  // diff: the space the loss is scored in: target (the paper's) | epsilon | sample | v (DiffusionPolicy)
  /// diff, eval's RQ1: further query rules judged on the same rollouts, each with its own threshold
  /// (ScoreRule names: "epsilon", "target@4"); they only watch, the robot acts on the main rule.
  std::vector<std::string> compare_scores;
  std::string precision = "float32";  // inference arithmetic of every method's policies: float32 | bfloat16 (DiffusionPolicy)
  double risk_quantile = 0.01;   // thrifty: gamma is this quantile of Q on robot data
  CriticConfig critic;           // thrifty
};

/// A Diff-DAgger score: the space the expected loss is measured in and the timesteps it draws from.
/// Written "SPACE" or "SPACE@K" (K: score_timesteps), e.g. "target" (the paper's), "epsilon",
/// "target@4" (t < 4 only).
struct ScoreRule {
  std::string space = "target";
  int timesteps = 0;  // 0: every timestep
  /// Throws Error naming `text` when it is not SPACE or SPACE@K with K >= 1.
  static ScoreRule parse(const std::string& text);
  std::string name() const;
};

/// Why a decision violates the query rule.
enum class QueryReason : uint8_t {
  kNone,   // it does not
  kScore,  // the score (loss or variance) is above its threshold, or not finite
  kRisk,   // thrifty: the critic's success estimate is below gamma
};

/// One decision of a method.
struct MethodDecision {
  Mat chunk;                 // T_p x action_dim, raw units
  float score = 0;           // the quantity the threshold applies to (loss or variance)
  float threshold = 0;
  bool violation = false;    // the query rule's verdict for this decision (core/gate.h, violates)
  QueryReason reason = QueryReason::kNone;
  float risk_q = -1;         // thrifty: min Q(o, a); -1 when not computed
  int score_rows = 0;        // diff: rows of noise the score is the mean of (fewer than N_b where screened); 0: not a loss
  std::vector<float> compare_scores;        // the score of each Method::compare_rules() rule
  std::vector<uint8_t> compare_violations;  // and its verdict
};

/// What one policy update cost and set.
struct UpdateReport {
  double train_s = 0;        // training wall-clock (reused: the training's when it ran)
  bool train_reused = false; // the ensemble's members came from the training cache (core/runtime.h)
  double threshold_s = 0;    // threshold setting wall-clock
  float threshold = 0;
  int pairs = 0;             // training pairs
  double final_loss = 0;     // mean training loss over the last steps
  // Diff-DAgger's screened threshold (0 for the other methods): the pairs it was the quantile of, and
  // how many of them were scored with all loss_samples rows. Its wall-clock grows with the second.
  int threshold_pairs = 0;
  int threshold_refined = 0;
};

class Method {
 public:
  virtual ~Method() = default;
  virtual std::string name() const = 0;
  /// False for BC: it never asks.
  virtual bool gated() const { return true; }
  /// The rules decide() also judges each decision by: diff's MethodConfig::compare_scores, and
  /// Thrifty's two halves ("novelty": the ensemble's spread; "risk": the critic), each alone.
  virtual std::vector<std::string> compare_rules() const { return {}; }
  /// Trains on `expert` (all expert data so far) and sets the threshold; `robot` holds the robot's
  /// own rollouts (Thrifty's critic learns from them).
  virtual UpdateReport update(const std::vector<Episode>& expert, const std::vector<RecordedEpisode>& robot,
                              const TrainConfig& train, const ProgressFn& progress = {}) = 0;
  /// Takes policies trained elsewhere instead of training them: loads `checkpoints` (one for diff and
  /// BC, one per member for the ensembles, trained as update() would have trained them on `expert`),
  /// then sets the threshold (and Thrifty's risk) as update() does after training. eval's RQ1 trains
  /// one ensemble per seed and gives its member 0 to Diff-DAgger: the very policy diff's own update
  /// would have trained. Throws Error naming a checkpoint that is missing or does not fit.
  /// `progress` follows the threshold's scoring passes where they are long enough to need it
  /// (Diff-DAgger's: every rule's, one after another, as one count). (The default, for methods that
  /// train nothing of their own, throws.)
  virtual UpdateReport adopt(const std::vector<std::string>& checkpoints, const std::vector<Episode>& expert,
                             const std::vector<RecordedEpisode>& robot, const ProgressFn& progress);
  /// Refits what the method learns from the robot's own rollouts, without retraining its policies:
  /// Thrifty's risk critic and its threshold gamma. Returns the seconds it took (0 for the others).
  virtual double refit_risk(const std::vector<Episode>& expert, const std::vector<RecordedEpisode>& robot) {
    (void)expert;
    (void)robot;
    return 0;
  }
  /// Generates a chunk for `obs` and applies the query rule.
  virtual MethodDecision decide(const Vec& obs, uint64_t seed) = 0;
  /// The current threshold (after the first update).
  virtual float threshold() const = 0;
  /// Thrifty's gamma: the risk half asks where the critic's success estimate is below it (NaN for
  /// the methods without a critic, and before Thrifty's first update or adopt()).
  virtual float risk_threshold() const { return NAN; }
  /// Writes the method's policy checkpoints into `dir` (policy.pt, or member_<i>.pt for ensembles).
  virtual void save(const std::string& dir) const = 0;
  /// Writes into `dir` (created if needed) everything continuing needs: the policies as save() writes
  /// them, and method.json with the threshold and the update count (and Thrifty's critic.pt and
  /// gamma). load_state() on a method built with the same name, configs and seed then decides and
  /// updates exactly as this one would. Throws Error naming the file when it cannot be written.
  void save_state(const std::string& dir) const;
  /// Reads save_state()'s files. Throws Error naming the file and field that is missing, corrupt, of
  /// another method or of another network.
  void load_state(const std::string& dir);

 protected:
  /// What save_state() writes beside the policies: files of its own in `dir`, and the returned
  /// fields of method.json; restore() reads both back. (The defaults, for methods that learn nothing
  /// of their own: no fields, and restoring throws.)
  virtual nlohmann::json state(const std::string& dir) const;
  virtual void restore(const nlohmann::json& state, const std::string& dir);
};

/// A method that acts with `policy` (borrowed, must outlive it) and never asks: for evaluating a
/// policy that is being trained or was loaded from a checkpoint.
std::unique_ptr<Method> act_with(const DiffusionPolicy& policy);

/// One row per method: what the command line, the console and the reports know about it.
struct MethodInfo {
  std::string name;               // "diff"
  std::string title;              // "Diff-DAgger"
  std::array<uint8_t, 3> color;   // in plots and reports (RGB)
  std::string score;              // what its score is ("expected diffusion loss"); empty: it has none
  std::string score_word;         // the same in a word or two, for one-line messages ("loss")
  bool gated = true;              // asks for help (false: BC)
  bool ensemble = false;          // trains MethodConfig::members policies
  bool learns_risk = false;       // also asks when a critic predicts failure (Thrifty)
};
const std::vector<MethodInfo>& method_registry();
/// The row of `name`; throws Error naming it and listing the known names.
const MethodInfo& method_info(const std::string& name);
/// The registry's names, in its order: "diff", "ensemble", "thrifty", "bc".
std::vector<std::string> method_names();
/// Builds a method by name; throws Error naming it when unknown.
std::unique_ptr<Method> make_method(const std::string& name, const PolicyConfig& policy, const MethodConfig& config,
                                    uint64_t seed);

}  // namespace dd
