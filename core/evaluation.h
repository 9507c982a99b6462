// Rollouts without intervention, for the paper's RQ1 (failure prediction) and RQ2 (task performance):
// the robot acts for the whole episode while the query rule only records whether it would have asked.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "core/env.h"
#include "core/method.h"
#include "core/progress.h"
#include "core/session.h"

namespace dd {

struct RolloutResult {
  bool success = false;
  bool queried = false;       // the rule would have asked (K violations in a row) at some point
  int first_query_step = -1;  // env step of the first would-be query
  std::vector<uint8_t> compare_queried;  // per Method::compare_rules(): that rule would have asked
  std::vector<int> compare_first_query_step;  // and the env step it would first have asked at (-1: never)
  std::string outcome;        // Env::outcome() at the end
  int steps = 0;
  int decisions = 0;
  double inference_s = 0;     // time spent deciding
};

/// How the robot acts and the gate counts in a rollout: the DAgger schedule's T_L, K, T_a and cadence.
struct RolloutSpec {
  int time_limit = 200;
  int patience = 2;
  int action_steps = 8;
  GateCadence gate_every = GateCadence::kChunk;
  static RolloutSpec of(const DaggerConfig& d) { return {d.time_limit, d.patience, d.action_steps, d.gate_every}; }
};

/// Runs `episodes` robot-only episodes from seeds seed, seed + 1, ... with time limit T_L, deciding
/// like the session does (a chunk per T_a steps; with GateCadence::kStep a scored chunk at every step).
/// When `recorded` is given, every episode's steps are appended to it as robot data (Thrifty's critic).
/// Without `recorded`, and when the work splits in two (core/runtime.h: two threads or more), two
/// one-thread child processes take alternate episodes (see evaluate_rollouts_each).
std::vector<RolloutResult> evaluate_rollouts(Env& env, Method& method, int episodes, const RolloutSpec& spec, uint64_t seed,
                                             const ProgressFn& progress = {}, std::vector<RecordedEpisode>* recorded = nullptr);

/// Episodes first .. end - 1 (episode e from seed `seed + e`, the method unchanged between them, so
/// each depends on its seed alone), handed to on_result(e, result) in episode order as they end.
/// When the work splits in two (core/runtime.h), two one-thread child processes take alternate
/// episodes: a batch-1 decision uses a second thread poorly (at down_dims 32,64,128 89 ms on two
/// threads against 134 ms on one), and the simulator's steps run in both. Each episode then gives
/// what a one-thread run gives. An on_result that throws stops the children.
void evaluate_rollouts_each(Env& env, Method& method, int first, int end, const RolloutSpec& spec, uint64_t seed,
                            const std::function<void(int episode, const RolloutResult&)>& on_result);

/// A rollout's result as one line of JSON (no newline), and back; the latter throws Error naming
/// what is wrong.
std::string rollout_to_json(const RolloutResult& r);
RolloutResult rollout_from_json(const std::string& line);

/// One episode of `expert` from `seed` (env and expert reset with it), run until the env says done:
/// every step flagged as an intervention, source "expert", reward 1 on the last step of a success.
RecordedEpisode expert_episode(Env& env, Expert& expert, uint64_t seed);

/// The confusion matrix of queries against failures: positive = query, actual positive = failure.
struct FailurePrediction {
  int tp = 0, fp = 0, tn = 0, fn = 0;
  double tpr = 0;       // queried failures / failures; NaN when no rollout failed
  double tnr = 0;       // unqueried successes / successes; NaN when none succeeded
  double f1 = 0;        // 2TP / (2TP + FP + FN); NaN when that is 0 / 0
  double accuracy = 0;  // NaN without rollouts
};
FailurePrediction failure_prediction(const std::vector<RolloutResult>& results);
/// The same for the compared rule `rule` (an index into Method::compare_rules()) on the same rollouts.
FailurePrediction failure_prediction(const std::vector<RolloutResult>& results, size_t rule);

/// The rollouts as the compared rule `rule` judged them: its verdict and first query step (-1 where
/// the step was not recorded, in rollouts written before compare_first_query_step) in `queried` and
/// `first_query_step`, the compared verdicts dropped. Throws Error when a rollout lacks the rule.
std::vector<RolloutResult> judged_by(const std::vector<RolloutResult>& results, size_t rule);

/// Fraction of successful rollouts.
double success_rate(const std::vector<RolloutResult>& results);

}  // namespace dd
