// Threshold calibration and the query rule with patience K.
//
// After each policy update the threshold is the alpha-quantile of a score (the expected diffusion
// loss, or the ensemble variance) over the training pairs. During a rollout each decision's score is
// a violation when it is above the threshold; the robot asks for help after K violations in a row.
#pragma once

#include <cmath>
#include <vector>

namespace dd {

/// The query rule's verdict on one score: above its threshold, or not finite (the policy is lost).
/// Every method judges its scores with it (and the gate counts its verdicts, QueryGate).
inline bool violates(float score, float threshold) { return !std::isfinite(score) || score > threshold; }

/// The alpha-quantile as sorted[floor(n * alpha)] (clamped to the last element).
/// Throws Error on an empty set, alpha outside [0, 1], or a non-finite value.
float quantile(std::vector<float> values, double alpha);

/// Spearman's rank correlation of two equally long score sets (ties ranked by position): how well one
/// scoring of the same pairs keeps the other's order, which is all a quantile threshold depends on.
/// Throws Error when the sizes differ or there are fewer than two values.
double spearman(const std::vector<float>& a, const std::vector<float>& b);

/// What one decision did to the gate.
struct GateDecision {
  bool violation = false;  // score > threshold
  int run = 0;             // violations in a row, this one included
  bool query = false;      // run reached patience: ask for the expert
};

/// Counts consecutive threshold violations within an episode.
class QueryGate {
 public:
  /// `patience` is K (>= 1).
  QueryGate(float threshold, int patience);

  /// Scores one decision. A non-finite score counts as a violation (the policy is lost).
  GateDecision observe(float score);
  /// Counts one decision whose violation a method has already judged (e.g. Thrifty's novelty or risk).
  GateDecision record(bool violation);
  /// Starts a new episode: the run of violations goes back to zero.
  void reset() { run_ = 0; }
  /// New threshold after a policy update; the current run is kept.
  void set_threshold(float threshold) { threshold_ = threshold; }

  float threshold() const { return threshold_; }
  int patience() const { return patience_; }
  int run() const { return run_; }

 private:
  float threshold_;
  int patience_;
  int run_ = 0;
};

}  // namespace dd
