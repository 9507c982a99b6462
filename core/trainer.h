// Training a diffusion policy on (observation, action chunk) pairs: AdamW, linear warm-up then cosine
// decay, gradient clipping, and an EMA of the weights that sampling uses.
#pragma once

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

/// Trains `policy` in place, continuing from its current weights with a fresh optimiser.
/// Refits the normalisers on `data` first when config.fit_normalizer. Deterministic for a fixed
/// config.seed. Throws Error on an empty data set or shapes that do not match the policy.
TrainStats train(DiffusionPolicy& policy, const ChunkDataset& data, const TrainConfig& config,
                 const ProgressFn& progress = {});

/// The learning rate at `step` of `total`: linear warm-up, then cosine decay to zero.
double scheduled_lr(const TrainConfig& config, int step, int total);

}  // namespace dd
