#include "core/ensemble.h"

#include <cmath>
#include <random>

#include <ATen/Parallel.h>
#include <spdlog/spdlog.h>

namespace dd {

PolicyEnsemble::PolicyEnsemble(const PolicyConfig& config, int members, uint64_t seed) : seed_(seed) {
  if (members < 2) throw Error("ensemble: needs at least 2 members, got " + std::to_string(members));
  for (int i = 0; i < members; ++i)
    members_.push_back(std::make_unique<DiffusionPolicy>(config, seed + static_cast<uint64_t>(i), /*announce=*/false));
  spdlog::info("ensemble: {} policies of {} parameters each", members, members_[0]->num_parameters());
}

void PolicyEnsemble::reinitialize(uint64_t seed) {
  for (int i = 0; i < size(); ++i) members_[static_cast<size_t>(i)]->reinitialize(seed + static_cast<uint64_t>(i));
}

std::vector<TrainStats> PolicyEnsemble::train(const std::vector<Episode>& episodes, const TrainConfig& config,
                                              const ProgressFn& progress) {
  if (episodes.empty()) throw Error("ensemble: no episodes to train on");
  std::mt19937_64 rng(seed_ ^ 0xb0075742ull);
  std::uniform_int_distribution<size_t> pick(0, episodes.size() - 1);
  std::vector<TrainStats> stats;
  const int horizon = members_[0]->config().horizon;
  const int per_member = config.steps_for(ChunkDataset::from_episodes(episodes, horizon).size());
  const int total = per_member * size();
  for (int m = 0; m < size(); ++m) {
    std::vector<Episode> resample;
    if (m == 0) {
      resample = episodes;
    } else {
      resample.reserve(episodes.size());
      for (size_t i = 0; i < episodes.size(); ++i) resample.push_back(episodes[pick(rng)]);
    }
    TrainConfig c = config;
    c.seed = config.seed + static_cast<uint64_t>(m) * 7919;
    const ProgressFn member_progress = progress ? ProgressFn([&, m](int done, int, double loss) {
      progress(std::min(total, m * per_member + done), total, loss);
    }) : ProgressFn{};
    stats.push_back(dd::train(*members_[static_cast<size_t>(m)], ChunkDataset::from_episodes(resample, horizon), c, member_progress));
  }
  return stats;
}

namespace {

// Across-member standard deviation and variance of chunk b, each averaged over the chunk's elements.
std::pair<float, float> spread_of(const std::vector<std::vector<Mat>>& samples, size_t b) {
  const float m = static_cast<float>(samples.size());
  Mat mean = Mat::Zero(samples[0][b].rows(), samples[0][b].cols());
  for (const auto& s : samples) mean += s[b];
  mean /= m;
  Mat var = Mat::Zero(mean.rows(), mean.cols());
  for (const auto& s : samples) var.array() += (s[b] - mean).array().square();
  var /= m;
  return {var.array().sqrt().mean(), var.mean()};
}

}  // namespace

std::vector<std::vector<Mat>> PolicyEnsemble::sample_members(const Mat& obs, uint64_t seed) const {
  std::vector<std::vector<Mat>> samples(members_.size());  // [member][row]
  auto sample = [&](int64_t m) { samples[static_cast<size_t>(m)] = members_[static_cast<size_t>(m)]->sample_batch(obs, seed + static_cast<uint64_t>(m)); };
  if (parallel_members_) {
    // One member per thread, each single-threaded inside (torch and OpenBLAS run serially in a
    // parallel region): small batches keep one core busy better than two.
    at::parallel_for(0, size(), 1, [&](int64_t begin, int64_t end) {
      for (int64_t m = begin; m < end; ++m) sample(m);
    });
  } else {
    for (int64_t m = 0; m < size(); ++m) sample(m);
  }
  return samples;
}

std::vector<std::vector<float>> PolicyEnsemble::spread(const Mat& obs, uint64_t seed) const {
  const std::vector<std::vector<Mat>> samples = sample_members(obs, seed);
  std::vector<std::vector<float>> out(2, std::vector<float>(static_cast<size_t>(obs.rows())));
  for (size_t b = 0; b < out[0].size(); ++b) std::tie(out[0][b], out[1][b]) = spread_of(samples, b);
  return out;
}

PolicyEnsemble::Decision PolicyEnsemble::decide(const Vec& obs, uint64_t seed) const {
  const std::vector<std::vector<Mat>> samples = sample_members(obs.transpose(), seed);
  Decision d;
  d.chunk = samples[0][0];
  std::tie(d.std, d.variance) = spread_of(samples, 0);
  return d;
}

std::vector<float> PolicyEnsemble::action_std(const Mat& obs, uint64_t seed) const { return spread(obs, seed)[0]; }

std::vector<float> PolicyEnsemble::action_variance(const Mat& obs, uint64_t seed) const { return spread(obs, seed)[1]; }

}  // namespace dd
