#include "core/chunks.h"

#include <algorithm>
#include <numeric>
#include <random>
#include <string>

#include "core/config.h"

namespace dd {

Mat ChunkDataset::chunk(int i) const {
  return Eigen::Map<const Mat>(chunks.row(i).data(), horizon, action_dim);
}

Mat ChunkDataset::action_rows() const {
  return Eigen::Map<const Mat>(chunks.data(), chunks.rows() * horizon, action_dim);
}

ChunkDataset ChunkDataset::subset(int n, uint64_t seed) const {
  if (n <= 0 || n >= size()) return *this;
  std::vector<int> idx(static_cast<size_t>(size()));
  std::iota(idx.begin(), idx.end(), 0);
  std::mt19937_64 rng(seed);
  std::shuffle(idx.begin(), idx.end(), rng);
  ChunkDataset s;
  s.horizon = horizon;
  s.action_dim = action_dim;
  s.obs.resize(n, obs_dim());
  s.chunks.resize(n, chunks.cols());
  for (int i = 0; i < n; ++i) {
    s.obs.row(i) = obs.row(idx[static_cast<size_t>(i)]);
    s.chunks.row(i) = chunks.row(idx[static_cast<size_t>(i)]);
  }
  return s;
}

ChunkDataset ChunkDataset::from_episodes(const std::vector<Episode>& episodes, int horizon) {
  if (episodes.empty()) throw Error("chunks: no episodes");
  if (horizon <= 0) throw Error("chunks: horizon must be positive");
  const Eigen::Index obs_dim = episodes.front().obs.cols();
  const Eigen::Index act_dim = episodes.front().actions.cols();
  Eigen::Index total = 0;
  for (size_t e = 0; e < episodes.size(); ++e) {
    const Episode& ep = episodes[e];
    const std::string where = "chunks: episode " + std::to_string(e);
    if (ep.obs.rows() != ep.actions.rows()) throw Error(where + ": obs and actions differ in length");
    if (ep.obs.rows() == 0) throw Error(where + ": empty");
    if (ep.obs.cols() != obs_dim || ep.actions.cols() != act_dim)
      throw Error(where + ": feature sizes differ from episode 0");
    if (!ep.obs.allFinite() || !ep.actions.allFinite())
      throw Error(where + ": contains NaN or infinite values");
    total += ep.obs.rows();
  }
  ChunkDataset d;
  d.horizon = horizon;
  d.action_dim = static_cast<int>(act_dim);
  d.obs.resize(total, obs_dim);
  d.chunks.resize(total, horizon * act_dim);
  Eigen::Index row = 0;
  for (const Episode& ep : episodes) {
    const Eigen::Index n = ep.obs.rows();
    for (Eigen::Index i = 0; i < n; ++i, ++row) {
      d.obs.row(row) = ep.obs.row(i);
      for (int k = 0; k < horizon; ++k) {
        const Eigen::Index src = std::min<Eigen::Index>(i + k, n - 1);
        d.chunks.block(row, k * act_dim, 1, act_dim) = ep.actions.row(src);
      }
    }
  }
  return d;
}

}  // namespace dd
