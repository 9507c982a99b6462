// Training pairs (observation, action chunk) built from episodes the way diffusion policy does:
// one pair per step, the chunk holding the next T_p actions, padded past the episode's end with
// its last action.
#pragma once

#include <cstdint>
#include <vector>

#include "core/types.h"

namespace dd {

/// One recorded episode: an observation and an action per step.
struct Episode {
  Mat obs;      // steps x obs_dim
  Mat actions;  // steps x action_dim
};

/// A flat set of training pairs.
struct ChunkDataset {
  int horizon = 0;     // T_p
  int action_dim = 0;  // actions per step
  Mat obs;             // pairs x obs_dim
  Mat chunks;          // pairs x (horizon * action_dim), each row a row-major (horizon x action_dim) chunk

  int size() const { return static_cast<int>(obs.rows()); }
  int obs_dim() const { return static_cast<int>(obs.cols()); }
  /// The chunk of pair i as (horizon x action_dim).
  Mat chunk(int i) const;
  /// All actions of all chunks as rows (pairs * horizon x action_dim), for fitting a normaliser.
  Mat action_rows() const;

  /// At most n pairs drawn without replacement with `seed` (a copy of all of them when n <= 0 or
  /// n >= size()), e.g. for calibrating a threshold on part of a large training set.
  ChunkDataset subset(int n, uint64_t seed) const;

  /// Builds pairs from episodes. Throws Error on inconsistent shapes or non-finite values.
  static ChunkDataset from_episodes(const std::vector<Episode>& episodes, int horizon);
};

}  // namespace dd
