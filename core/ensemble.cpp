#include "core/ensemble.h"

#include <chrono>
#include <cmath>
#include <mutex>
#include <numeric>
#include <random>

#include <unistd.h>

#include <cstdio>
#include <filesystem>

#include <ATen/Parallel.h>
#include <c10/util/hash.h>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "core/isolate.h"
#include "core/runtime.h"
#include "core/text_file.h"

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
  const std::string dir = ensemble_train_cache();
  last_train_reused_ = false;
  std::string key;
  if (!dir.empty()) {
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec) throw Error(dir + ": cannot create the ensemble training cache: " + ec.message());
    key = cache_key(episodes, config);
    const std::string entry = (fs::path(dir) / key).string();
    std::vector<TrainStats> stats;
    if (fs::exists(fs::path(entry) / "train.json") && load_cached(entry, stats)) {
      last_train_reused_ = true;
      spdlog::info("ensemble: the same members trained on the same data before ({}): loaded, not trained again "
                   "({:.1f} s when they were trained)", entry, last_train_s_);
      if (progress) {
        const int total = static_cast<int>(stats.size() * stats[0].losses.size());
        progress(total, total, stats[0].last_mean());
      }
      return stats;
    }
    std::error_code gone;
    fs::remove_all(entry, gone);  // an unreadable entry (if any) makes way for the members trained now
  }
  const auto start = std::chrono::steady_clock::now();
  std::vector<TrainStats> stats = train_now(episodes, config, progress);
  last_train_s_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (!key.empty()) {
    try {
      store_cached(dir, key, stats);
    } catch (const std::exception& e) {  // a full disk costs the next run its shortcut, not this run its members
      spdlog::warn("ensemble: could not keep the trained members in {}: {}", dir, e.what());
    }
  }
  return stats;
}

std::string PolicyEnsemble::cache_key(const std::vector<Episode>& episodes, const TrainConfig& config) const {
  // How the members train decides their float rounding: one thread each in child processes or in
  // threads of this process (the same weights as --threads 1), or one after another on every thread.
  std::string how = "one thread each";
  if (!parallel_members_ && at::get_num_threads() > 1)
    how = fmt::format("one after another, {} threads, split {}", at::get_num_threads(), split_in_two_processes());
  how += fused_optimizer_on() ? ", fused AdamW" : ", torch's AdamW";
  std::string material = fmt::format("diffdagger ensemble training 3\n{}\nseed {}\nmembers {}\n{}\n",
                                     nlohmann::json(config).dump(), seed_, size(), how);
  // the members as they stand (weights, EMA weights, normalisers, config): their checkpoints' bytes,
  // made in memory (a file's checkpoint names its zip entries after the file, which a key must not see)
  for (const auto& m : members_) material += m->checkpoint_bytes();
  auto put = [&](const Mat& m) {
    material += fmt::format("{}x{}\n", m.rows(), m.cols());
    material.append(reinterpret_cast<const char*>(m.data()), static_cast<size_t>(m.size()) * sizeof(m.data()[0]));
  };
  for (const Episode& e : episodes) {
    put(e.obs);
    put(e.actions);
  }
  return c10::sha1(material).str();
}

void PolicyEnsemble::load_members(const std::vector<std::string>& files) {
  if (static_cast<int>(files.size()) != size())
    throw Error(fmt::format("ensemble: {} member files for {} members", files.size(), size()));
  for (int m = 0; m < size(); ++m) {
    const std::string& file = files[static_cast<size_t>(m)];
    const auto loaded = DiffusionPolicy::from_checkpoint(file);
    const std::vector<std::string> diffs = config_differences(loaded->config(), members_[static_cast<size_t>(m)]->config());
    if (!diffs.empty()) {
      std::string msg = fmt::format("{}: checkpoint does not match member {}'s config (checkpoint vs member):", file, m);
      for (const auto& d : diffs) msg += "\n  " + d;
      throw Error(msg);
    }
  }
  for (int m = 0; m < size(); ++m) members_[static_cast<size_t>(m)]->load(files[static_cast<size_t>(m)]);
}

bool PolicyEnsemble::load_cached(const std::string& entry, std::vector<TrainStats>& stats) {
  const std::string index = entry + "/train.json";
  try {
    const nlohmann::json j = nlohmann::json::parse(read_text(index));
    const auto& members = j.at("members");
    if (!members.is_array() || static_cast<int>(members.size()) != size())
      throw Error(fmt::format("field 'members' holds {} members, the ensemble has {}", members.size(), size()));
    std::vector<TrainStats> out(static_cast<size_t>(size()));
    for (int m = 0; m < size(); ++m) {
      out[static_cast<size_t>(m)].seconds = members[static_cast<size_t>(m)].at("seconds").get<double>();
      out[static_cast<size_t>(m)].losses = members[static_cast<size_t>(m)].at("losses").get<std::vector<float>>();
    }
    const double seconds = j.at("seconds").get<double>();
    std::vector<std::string> files;
    for (int m = 0; m < size(); ++m) files.push_back(fmt::format("{}/member_{}.pt", entry, m));
    load_members(files);  // a bad entry leaves the ensemble as it was
    stats = std::move(out);
    last_train_s_ = seconds;
    return true;
  } catch (const std::exception& e) {
    const std::string why = e.what();
    spdlog::warn("ensemble: the cache entry {} is unreadable ({}); training instead", entry, why.substr(0, why.find('\n')));
    return false;
  }
}

void PolicyEnsemble::store_cached(const std::string& dir, const std::string& key, const std::vector<TrainStats>& stats) const {
  // written under a temporary name and renamed whole: a reader sees a complete entry or none
  const fs::path entry = fs::path(dir) / key, tmp = fs::path(dir) / fmt::format("{}.tmp.{}", key, ::getpid());
  fs::create_directories(tmp);
  nlohmann::json members = nlohmann::json::array();
  for (int m = 0; m < size(); ++m) {
    members_[static_cast<size_t>(m)]->save((tmp / fmt::format("member_{}.pt", m)).string());
    members.push_back({{"seconds", stats[static_cast<size_t>(m)].seconds}, {"losses", stats[static_cast<size_t>(m)].losses}});
  }
  write_text((tmp / "train.json").string(), nlohmann::json{{"seconds", last_train_s_}, {"members", members}}.dump() + "\n");
  std::error_code ec;
  fs::rename(tmp, entry, ec);
  if (ec) fs::remove_all(tmp, ec);  // another process stored the same entry first
}

std::vector<TrainStats> PolicyEnsemble::train_now(const std::vector<Episode>& episodes, const TrainConfig& config,
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
