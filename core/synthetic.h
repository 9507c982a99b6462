// Synthetic data sets for tests and demos.
#pragma once

#include <cstdint>
#include <vector>

#include "core/chunks.h"

namespace dd {

/// Bimodal episodes: the same observation distribution (uniform in [-1, 1]^obs_dim) with actions
/// that follow one of two well-separated modes per episode, chosen 50/50: action dimension 0 sits
/// near +1 or near -1 (noise std `noise`), the other dimensions near 0.
/// Returns `n_episodes` episodes of `length` steps; the mode of episode e is `modes[e]` (+1 or -1)
/// when `modes` is given.
std::vector<Episode> bimodal_episodes(int n_episodes, int length, int obs_dim, int action_dim, uint64_t seed,
                                      float noise = 0.05f, std::vector<int>* modes = nullptr);

/// Which mode a chunk follows: +1 or -1 when the mean of action dimension 0 is beyond +-0.5,
/// 0 when it lies between the modes.
int bimodal_mode(const Mat& chunk);

}  // namespace dd
