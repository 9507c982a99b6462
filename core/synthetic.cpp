#include "core/synthetic.h"

#include <random>

namespace dd {

std::vector<Episode> bimodal_episodes(int n_episodes, int length, int obs_dim, int action_dim, uint64_t seed,
                                      float noise, std::vector<int>* modes) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> uniform(-1.f, 1.f);
  std::normal_distribution<float> gauss(0.f, noise);
  std::vector<Episode> episodes(static_cast<size_t>(n_episodes));
  if (modes) modes->clear();
  for (auto& ep : episodes) {
    const int mode = (rng() & 1) ? 1 : -1;
    if (modes) modes->push_back(mode);
    ep.obs.resize(length, obs_dim);
    ep.actions.resize(length, action_dim);
    for (int i = 0; i < length; ++i) {
      for (int j = 0; j < obs_dim; ++j) ep.obs(i, j) = uniform(rng);
      for (int j = 0; j < action_dim; ++j) ep.actions(i, j) = (j == 0 ? static_cast<float>(mode) : 0.f) + gauss(rng);
    }
  }
  return episodes;
}

int bimodal_mode(const Mat& chunk) {
  const float m = chunk.col(0).mean();
  return m > 0.5f ? 1 : (m < -0.5f ? -1 : 0);
}

}  // namespace dd
