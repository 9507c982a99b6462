#include "core/ensemble.h"

#include <cmath>
#include <mutex>
#include <numeric>
#include <random>

#include <unistd.h>

#include <cstdio>
#include <filesystem>

#include <ATen/Parallel.h>
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "core/isolate.h"

namespace dd {

namespace fs = std::filesystem;

PolicyEnsemble::PolicyEnsemble(const PolicyConfig& config, int members, uint64_t seed) : seed_(seed) {
  if (members < 2) throw Error("ensemble: needs at least 2 members, got " + std::to_string(members));
  for (int i = 0; i < members; ++i)
    members_.push_back(std::make_unique<DiffusionPolicy>(config, seed + static_cast<uint64_t>(i), /*announce=*/false));
  spdlog::info("ensemble: {} policies of {} parameters each", members, members_[0]->num_parameters());
}

void PolicyEnsemble::reinitialize(uint64_t seed) {
  for (int i = 0; i < size(); ++i) members_[static_cast<size_t>(i)]->reinitialize(seed + static_cast<uint64_t>(i));
}

std::vector<std::vector<Episode>> PolicyEnsemble::member_data(const std::vector<Episode>& episodes) const {
  if (episodes.empty()) throw Error("ensemble: no episodes to train on");
  // Every member's data, drawn first and in member order: the same resamples however they train.
  std::mt19937_64 rng(seed_ ^ 0xb0075742ull);
  std::uniform_int_distribution<size_t> pick(0, episodes.size() - 1);
  std::vector<std::vector<Episode>> data(members_.size());
  data[0] = episodes;
  for (size_t m = 1; m < data.size(); ++m) {
    data[m].reserve(episodes.size());
    for (size_t i = 0; i < episodes.size(); ++i) data[m].push_back(episodes[pick(rng)]);
  }
  return data;
}

TrainStats PolicyEnsemble::train_member(int m, const std::vector<Episode>& member_episodes, const TrainConfig& config,
                                        const ProgressFn& progress) {
  TrainConfig c = config;
  c.seed = config.seed + static_cast<uint64_t>(m) * 7919;
  const int horizon = members_[0]->config().horizon;
  return dd::train(*members_[static_cast<size_t>(m)], ChunkDataset::from_episodes(member_episodes, horizon), c, progress);
}

std::vector<TrainStats> PolicyEnsemble::train(const std::vector<Episode>& episodes, const TrainConfig& config,
                                              const ProgressFn& progress) {
  const std::vector<std::vector<Episode>> data = member_data(episodes);
  const int horizon = members_[0]->config().horizon;
  const int per_member = config.steps_for(ChunkDataset::from_episodes(episodes, horizon).size());
  const int total = per_member * size();
  std::vector<TrainStats> stats(members_.size());
  std::vector<int> done(members_.size(), 0);
  std::mutex progress_mutex;
  auto train_one = [&](int64_t m) {
    const ProgressFn member_progress = progress ? ProgressFn([&, m](int steps, int, double loss) {
      std::lock_guard<std::mutex> lock(progress_mutex);
      done[static_cast<size_t>(m)] = steps;
      progress(std::min(total, std::accumulate(done.begin(), done.end(), 0)), total, loss);
    }) : ProgressFn{};
    stats[static_cast<size_t>(m)] = train_member(static_cast<int>(m), data[static_cast<size_t>(m)], config, member_progress);
  };
  if (parallel_members_ && train_in_processes_ && at::get_num_threads() > 1) {
    train_in_children(data, config, total, progress, stats);
  } else if (parallel_members_ && at::get_num_threads() > 1) {
    // One member per thread, one thread inside each: a training step uses two threads poorly, so
    // two members side by side get through almost twice the steps. Inside the parallel region
    // torch's operators run single-threaded, so each member trains as it would with --threads 1.
    at::parallel_for(0, size(), 1, [&](int64_t begin, int64_t end) {
      for (int64_t m = begin; m < end; ++m) train_one(m);
    });
  } else {
    for (int64_t m = 0; m < size(); ++m) train_one(m);
  }
  return stats;
}

void PolicyEnsemble::train_in_children(const std::vector<std::vector<Episode>>& data, const TrainConfig& config, int total,
                                       const ProgressFn& progress, std::vector<TrainStats>& stats) {
  // Each child trains one member on one thread, saves it to a temporary checkpoint and returns its
  // training stats and the file's name; progress comes back as "steps loss" messages.
  const fs::path dir = fs::temp_directory_path();
  auto job = [&](int m, const ReportFn& report) {
    const ProgressFn member_progress = [&](int steps, int, double loss) { report(fmt::format("{} {}", steps, loss)); };
    const TrainStats s = train_member(m, data[static_cast<size_t>(m)], config, progress ? member_progress : ProgressFn{});
    const std::string file = (dir / fmt::format("dd_member_{}_{}.pt", ::getpid(), m)).string();
    members_[static_cast<size_t>(m)]->save(file);
    Bytes b;
    b.put(s.seconds);
    b.put_all(s.losses.data(), s.losses.size());
    b.put_string(file);
    return std::move(b.out);
  };
  std::vector<int> done(members_.size(), 0);
  auto on_report = [&](int m, const std::string& message) {
    int steps = 0;
    double loss = 0;
    if (std::sscanf(message.c_str(), "%d %lf", &steps, &loss) != 2) return;
    done[static_cast<size_t>(m)] = steps;
    progress(std::min(total, std::accumulate(done.begin(), done.end(), 0)), total, loss);
  };
  // Every member at once, the kernel sharing the cores between them: 5 one-thread members on 2 cores
  // take 2.5 members' time, against 3 when they go 2 at a time (measured: 8.4 s against 11.1 s,
  // BM_EnsembleTrain_32_64_128).
  const std::vector<std::string> results = run_in_children(size(), size(), "ensemble training", job, on_report);
  for (size_t m = 0; m < results.size(); ++m) {
    Bytes r(results[m], "ensemble training: member " + std::to_string(m) + "'s child process");
    stats[m].seconds = r.get<double>();
    stats[m].losses = r.get_all<float>();
    const std::string file = r.get_string();
    try {
      members_[m]->load(file);
    } catch (...) {
      std::error_code ec;
      fs::remove(file, ec);
      throw;
    }
    std::error_code ec;
    fs::remove(file, ec);
  }
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

std::vector<std::vector<Mat>> PolicyEnsemble::sample_members(const Mat& obs, uint64_t seed, const ProgressFn& progress) const {
  std::vector<std::vector<Mat>> samples(members_.size());  // [member][row]
  std::mutex progress_mutex;
  int sampled = 0;
  auto sample = [&](int64_t m) {
    samples[static_cast<size_t>(m)] = members_[static_cast<size_t>(m)]->sample_batch(obs, seed + static_cast<uint64_t>(m));
    if (!progress) return;
    std::lock_guard<std::mutex> lock(progress_mutex);
    progress(++sampled, size(), NAN);
  };
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

std::vector<std::vector<float>> PolicyEnsemble::spread(const Mat& obs, uint64_t seed, const ProgressFn& progress) const {
  const std::vector<std::vector<Mat>> samples = sample_members(obs, seed, progress);
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

std::vector<float> PolicyEnsemble::action_variance(const Mat& obs, uint64_t seed, const ProgressFn& progress) const {
  return spread(obs, seed, progress)[1];
}

}  // namespace dd
