// An ensemble of diffusion policies trained on bootstrapped resamples of the demonstrations, the
// uncertainty estimate of Ensemble-DAgger: the spread of the members' generated chunks.
#pragma once

#include <memory>
#include <vector>

#include "core/chunks.h"
#include "core/policy.h"
#include "core/trainer.h"

namespace dd {

class PolicyEnsemble {
 public:
  /// `members` policies of the same config, initialised from seed, seed + 1, ...
  PolicyEnsemble(const PolicyConfig& config, int members, uint64_t seed);

  /// Re-initialises every member (member i from seed + i): an update that trains from scratch.
  void reinitialize(uint64_t seed);

  int size() const { return static_cast<int>(members_.size()); }
  DiffusionPolicy& member(int i) { return *members_[static_cast<size_t>(i)]; }
  const DiffusionPolicy& member(int i) const { return *members_[static_cast<size_t>(i)]; }

  /// Trains member 0, the one that acts, on all the episodes, and every other member on its own
  /// bootstrap resample (as many episodes, drawn with replacement): the acting policy sees the same
  /// data as Diff-DAgger's and BC's, the others supply the spread. Progress counts steps over all members.
  ///
  /// With a cache folder set (core/runtime.h's set_ensemble_train_cache), training is memoised: the key
  /// is a SHA-1 of everything it reads (every member's weights, EMA weights and normalisers, the
  /// episodes, the config, the ensemble's seed and how the members train), and an entry holds the
  /// trained members and their stats. A hit loads the members (bit for bit what training would give,
  /// as training is deterministic) and reports the wall-clock the training took when it ran; a miss
  /// trains and stores them. An unreadable entry is reported and trained over.
  std::vector<TrainStats> train(const std::vector<Episode>& episodes, const TrainConfig& config,
                                const ProgressFn& progress = {});
  /// The last train()'s wall-clock (for a cache hit: the training's when it ran), and whether it
  /// came from the cache.
  double last_train_seconds() const { return last_train_s_; }
  bool last_train_reused() const { return last_train_reused_; }

  /// Loads member m from files[m], all or nothing: every file is read and checked against its
  /// member's network before any member changes, so that a missing, corrupt or mismatched file
  /// leaves the ensemble as it was. Throws Error naming the first bad file.
  void load_members(const std::vector<std::string>& files);

  /// What each member trains on (train() draws the same): member 0 all of `episodes`, member i its
  /// own bootstrap resample, drawn from the ensemble's seed.
  std::vector<std::vector<Episode>> member_data(const std::vector<Episode>& episodes) const;
  /// Trains member `m` alone on its data (member_data(...)[m]), as train() would: for callers that
  /// train members in separate processes or keep each one as it finishes.
  TrainStats train_member(int m, const std::vector<Episode>& member_episodes, const TrainConfig& config,
                          const ProgressFn& progress = {});

  /// Per observation row (B x obs_dim): each member generates one chunk; the result is the
  /// standard deviation across members of every chunk element, averaged over time and action
  /// dimensions (raw action units).
  std::vector<float> action_std(const Mat& obs, uint64_t seed) const;
  /// Same, as a variance (the mean over elements of the across-member variance). `progress` counts
  /// the members that have sampled (value NaN): a threshold pass over thousands of pairs takes minutes.
  std::vector<float> action_variance(const Mat& obs, uint64_t seed, const ProgressFn& progress = {}) const;

  /// One control decision: every member generates a chunk for `obs`; the first member's chunk (the
  /// member trained on all the data) is the one executed, and the spread of all of them is the uncertainty.
  struct Decision {
    Mat chunk;            // T_p x action_dim, raw units
    float variance = 0;   // mean over elements of the across-member variance
    float std = 0;        // mean over elements of the across-member standard deviation
  };
  Decision decide(const Vec& obs, uint64_t seed) const;

  /// Members train and sample side by side, one per thread (the default, with more than one
  /// thread), or one after another with every thread inside each (the benchmarks' baseline). The
  /// weights and chunks are those of a one-thread run either way.
  void set_parallel_members(bool on) { parallel_members_ = on; }
  /// With parallel members, train them in child processes (the default; all members at once)
  /// instead of threads of this process. Same weights either way: each member trains on
  /// one thread. Processes are about twice as fast on 2 cores (run_in_children says why); threads
  /// are for callers that must not fork.
  void set_train_in_processes(bool on) { train_in_processes_ = on; }

 private:
  std::vector<TrainStats> train_now(const std::vector<Episode>& episodes, const TrainConfig& config, const ProgressFn& progress);
  std::string cache_key(const std::vector<Episode>& episodes, const TrainConfig& config) const;
  bool load_cached(const std::string& entry, std::vector<TrainStats>& stats);
  void store_cached(const std::string& dir, const std::string& key, const std::vector<TrainStats>& stats) const;
  void train_in_children(const std::vector<std::vector<Episode>>& data, const TrainConfig& config, int total,
                         const ProgressFn& progress, std::vector<TrainStats>& stats);
  std::vector<std::vector<Mat>> sample_members(const Mat& obs, uint64_t seed, const ProgressFn& progress = {}) const;  // [member][row]
  std::vector<std::vector<float>> spread(const Mat& obs, uint64_t seed, const ProgressFn& progress = {}) const;  // [0]: std, [1]: var
  std::vector<std::unique_ptr<DiffusionPolicy>> members_;
  uint64_t seed_;
  bool parallel_members_ = true;
  bool train_in_processes_ = true;
  double last_train_s_ = 0;
  bool last_train_reused_ = false;
};

}  // namespace dd
