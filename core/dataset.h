// Data sets of episodes in robomimic's HDF5 layout, so robomimic and diffusion_policy read them with
// their loaders' defaults:
//
//   /data                            attrs: total (steps, int64), env_args (JSON string: env_name,
//                                    type, env_kwargs, as robomimic's metadata reader expects)
//   /data/demo_<i>                   attrs: num_samples (int64), success (int), source (string)
//   /data/demo_<i>/obs/<key>         (T x obs_dim) float32; this project writes one key, "state"
//   /data/demo_<i>/next_obs/<key>    (T x obs_dim) float32: obs shifted by one step; the last row
//                                    repeats the last observation (the state after the final
//                                    action is not recorded)
//   /data/demo_<i>/actions           (T x action_dim) float32
//   /data/demo_<i>/rewards           (T) float32
//   /data/demo_<i>/dones             (T) uint8
//   /data/demo_<i>/intervention      (T) uint8: 1 where the expert (human or scripted) acted
//   /data/demo_<i>/actor             (T) uint8, written by DAgger sessions: who acted at each step, an
//                                    index into its attribute `labels` (kActorLabels, comma-separated)
//   /mask/train, /mask/valid         robomimic's filter keys: demo names as byte strings; every
//                                    tenth demo (demo_9, demo_19, ...) is for validation
//
// Appending is crash-safe: every finished episode reaches the disk before append() returns, and a
// process killed at any moment (kill -9, a full disk) leaves the previous complete file in place.
// The price is a copy of the file per episode (written beside it, then renamed over it).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/chunks.h"
#include "core/types.h"

namespace dd {

/// Who acts at a step, as /data/demo_<i>/actor records it (the order of dd::Control in core/session.h).
inline constexpr const char* kActorLabels[] = {"robot", "expert_query", "expert_timeout", "expert_demo", "operator"};

/// One recorded episode.
struct RecordedEpisode {
  Mat obs;                            // T x obs_dim
  Mat actions;                        // T x action_dim
  std::vector<float> rewards;         // T (empty: zeros)
  std::vector<uint8_t> dones;         // T (empty: 1 on the last step)
  std::vector<uint8_t> intervention;  // T (empty: zeros)
  std::vector<uint8_t> actor;         // T (empty: not recorded): index into kActorLabels
  bool success = false;
  std::string source = "expert";      // expert | intervention | robot

  int steps() const { return static_cast<int>(obs.rows()); }
  /// The steps where the expert acted, as an Episode for training (runs of flagged steps are joined).
  Episode expert_steps() const;
  /// All steps as an Episode.
  Episode all_steps() const;
};

/// What a data set holds.
struct DatasetInfo {
  std::string path;
  int episodes = 0;
  int64_t total = 0;          // steps
  int64_t intervention_steps = 0;
  int successes = 0;
  int obs_dim = 0, action_dim = 0;
  std::string env_args;       // JSON
};

/// Appends episodes to an HDF5 file, creating it if needed.
class DatasetWriter {
 public:
  /// Opens `path` for appending. A new file gets `env_args` (JSON); an existing one must be a readable
  /// data set whose env_args match, or this throws Error naming the file and field.
  DatasetWriter(std::string path, std::string env_args);

  /// Writes one finished episode durably (fsync + rename). Throws Error naming the file on failure;
  /// the file on disk then still holds every earlier episode.
  void append(const RecordedEpisode& episode);
  int episodes() const { return episodes_; }
  const std::string& path() const { return path_; }

 private:
  std::string path_, env_args_;
  int episodes_ = 0;
  int64_t total_ = 0;
};

/// Writes `episodes` as a new file at `path` in one pass (replacing any file there only once the new
/// one is complete and on disk). Throws Error naming the file.
void write_dataset(const std::string& path, const std::string& env_args, const std::vector<RecordedEpisode>& episodes);

/// Reads every episode. Throws Error naming the file and the group or field that is missing or
/// malformed. `info` (optional) receives the summary.
std::vector<RecordedEpisode> read_dataset(const std::string& path, DatasetInfo* info = nullptr);
/// Reads only the summary.
DatasetInfo dataset_info(const std::string& path);

}  // namespace dd
