// Training a diffusion policy on (observation, action chunk) pairs: AdamW, linear warm-up then cosine
// decay, gradient clipping, and an EMA of the weights that sampling uses.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/config.h"
#include "core/progress.h"

namespace dd {

class DiffusionPolicy;
struct ChunkDataset;

/// What a training call did.
struct TrainStats {
  std::vector<float> losses;  // per-step training loss
  double seconds = 0.0;       // wall-clock time
  /// Mean loss over the first / last `window` steps (for "loss falls" checks and reports).
  double first_mean(int window = 50) const;
  double last_mean(int window = 50) const;
};

/// A training run over one data set, one gradient step at a time (for benchmarks and for callers that
/// interleave training with other work). Construction refits the normalisers when asked and builds
/// the optimiser; the EMA restarts from the live weights.
class Trainer {
 public:
  Trainer(DiffusionPolicy& policy, const ChunkDataset& data, const TrainConfig& config);
  ~Trainer();
  Trainer(const Trainer&) = delete;
  Trainer& operator=(const Trainer&) = delete;

  /// One gradient step (minibatch, loss, AdamW, EMA update); returns the loss. Throws Error if the loss
  /// is not finite.
  float step();
  int steps_done() const;
  /// The process id of the child that computes half of each step (core/runtime.h's
  /// split_in_two_processes, with the fused optimiser), or -1 when this
  /// process trains alone (one thread, a small minibatch, or the child died and it went on alone).
  int worker_pid() const;

  /// Writes what continuing needs beyond the policy's own checkpoint (steps done, the optimiser's
  /// moments, the EMA weights, the minibatch generator) to `path`, atomically; with the policy saved
  /// beside it, resume() on a new Trainer over the same data and config continues as if never stopped.
  /// Throws Error naming the file when it cannot be written.
  void save_state(const std::string& path) const;
  /// Reads save_state()'s file into this trainer (built over the same data and config, its policy
  /// loaded from the checkpoint saved at the same step). Throws Error naming the file and what does
  /// not match (the total number of steps, the parameter shapes) or when it is missing or corrupt.
  void resume(const std::string& path);

 private:
  struct State;
  std::unique_ptr<State> state_;
};

/// Trains `policy` in place, continuing from its current weights with a fresh optimiser, for
/// config.steps_for(pairs) steps.
/// Refits the normalisers on `data` first when config.fit_normalizer. Deterministic for a fixed
/// config.seed. Throws Error on an empty data set or shapes that do not match the policy.
TrainStats train(DiffusionPolicy& policy, const ChunkDataset& data, const TrainConfig& config,
                 const ProgressFn& progress = {});

/// Trainers built after this call update the weights with the fused optimiser (the default: the
/// parameters, gradients, AdamW moments and EMA weights live in flat buffers, and clipping, AdamW and
/// the EMA are a few passes over them) or with torch's AdamW per parameter tensor (the benchmarks'
/// baseline). Both compute the same update.
void set_fused_optimizer(bool on);
bool fused_optimizer_on();

/// The learning rate at `step` of `total`: linear warm-up, then cosine decay to zero.
double scheduled_lr(const TrainConfig& config, int step, int total);

}  // namespace dd
