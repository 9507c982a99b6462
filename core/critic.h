// Thrifty-DAgger's risk estimate: Q(o, a), the discounted chance of finishing the task from
// observation o after action a. Twin MLPs with a sigmoid output, the minimum of the two read out;
// sparse reward 1 on the step that succeeds.
//
// Simplification (stated in the README): targets are SARSA-style, r + discount * (1 - done) *
// min Q'(o', a') with a' the action the data actually took next, instead of a' drawn from the
// current diffusion policy (which would need a 16-step sampling per transition and target update).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/dataset.h"
#include "core/progress.h"
#include "core/types.h"

namespace dd {

struct CriticConfig {
  int hidden = 128;          // units per hidden layer (two layers)
  int steps = 1500;          // gradient steps per training call
  int batch_size = 256;
  double lr = 1e-3;
  double discount = 0.9999;  // as in the paper's Thrifty setting
  double polyak = 0.995;     // target network averaging
  uint64_t seed = 0;
};

class RiskCritic {
 public:
  RiskCritic(int obs_dim, int action_dim, const CriticConfig& config = {});
  ~RiskCritic();
  RiskCritic(const RiskCritic&) = delete;
  RiskCritic& operator=(const RiskCritic&) = delete;
  RiskCritic(RiskCritic&&) noexcept;
  RiskCritic& operator=(RiskCritic&&) noexcept;

  /// Fits Q on the transitions of `episodes` (demonstrations and robot rollouts; reward 1 on the
  /// successful step, done on the last). Returns the final TD loss. `progress` counts the gradient
  /// steps, with the running TD loss.
  float train(const std::vector<RecordedEpisode>& episodes, const ProgressFn& progress = {});
  /// min(Q1, Q2) for each (obs row, action row), in [0, 1].
  std::vector<float> q(const Mat& obs, const Mat& actions) const;

  /// Writes the twins' weights and the normalisers to one file (atomically), so that a stopped run
  /// continues with the critic it had: train() goes on from these weights. Throws Error naming the file.
  void save(const std::string& path) const;
  /// Reads save()'s file; throws Error naming the file when it is missing, corrupt or of other sizes.
  void load(const std::string& path);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace dd
