// The diffusion policy: network, noise schedule and normalisers behind a torch-free interface.
//
// Observations and actions go in and come out in raw units; the policy normalises internally.
// Sampling and the expected loss use the EMA weights; training updates the live weights and the EMA.
//
//   DiffusionPolicy policy(config, /*seed=*/0);
//   train(policy, data, train_config);                  // core/trainer.h
//   Mat chunk = policy.sample(obs, seed);               // (T_p x A), raw units
//   float loss = policy.expected_loss(obs, chunk, seed) // eq. 2 over N_b (noise, timestep) pairs
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/config.h"
#include "core/normalizer.h"
#include "core/progress.h"
#include "core/types.h"

namespace dd {

struct ChunkDataset;

/// Default N_b: (noise, timestep) samples per expected loss.
constexpr int kDefaultLossSamples = 512;

/// Which weights score the expected loss: the EMA weights that also sample (the default) or the raw
/// training weights (the authors' released code).
enum class ScoreWeights { kEma, kRaw };

/// The space the expected loss is measured in. kTarget: the training objective's own (the paper's
/// score). The three targets are conversions of one another at x_t, so a network trained with any of
/// them can be scored in any: per timestep, with a v-trained network, the epsilon-space loss is
/// alpha_bar_t times the v-space loss and the sample-space loss (1 - alpha_bar_t) times it (the
/// scores then weight the timesteps differently).
enum class ScoreSpace { kTarget, kEpsilon, kSample, kVelocity };
ScoreSpace score_space_from(const std::string& name);  // "target" | "epsilon" | "sample" | "v"
std::string to_string(ScoreSpace s);

/// The arithmetic of inference (sampling and expected losses): float32, or bfloat16 products with
/// float32 accumulation (an option, faster on CPUs with AVX-512 BF16; its agreement with float32 is
/// measured by tests/bench/precision_agreement). Training is always float32.
enum class InferencePrecision { kFloat32, kBFloat16 };
InferencePrecision inference_precision_from(const std::string& name);  // "float32" | "bfloat16"
std::string to_string(InferencePrecision p);

/// One control decision: the generated chunk and its expected diffusion loss.
struct Decision {
  Mat chunk;                // T_p x action_dim, raw units
  float loss = 0.f;         // expected diffusion loss of (obs, chunk)
  std::vector<float> also;  // the same rows' loss in each of decide()'s `also` spaces, in order
  int rows = 0;             // rows of noise `loss` is the mean of (decide_screened: fewer where it stopped early)
};

/// A threshold over training pairs: the alpha-quantile of their expected losses.
struct LossQuantile {
  float threshold = 0;
  int pairs = 0;          // pairs it is over
  int refined = 0;        // pairs scored with the full n_samples rows (all of them without screening)
  int screen_samples = 0; // rows per pair of the screening pass (0: none)
  /// A pair is left at its screening estimate only when the estimate plus this many standard
  /// errors is below the threshold.
  static constexpr float kScreenZ = 5;
};

class DiffusionPolicy {
 public:
  /// Builds a freshly initialised network (weights drawn from `seed`) and, when `announce`, logs its
  /// parameter count. Throws Error naming the field if the config is invalid.
  DiffusionPolicy(const PolicyConfig& config, uint64_t seed, bool announce = true);
  ~DiffusionPolicy();
  DiffusionPolicy(const DiffusionPolicy&) = delete;
  DiffusionPolicy& operator=(const DiffusionPolicy&) = delete;

  const PolicyConfig& config() const;
  int64_t num_parameters() const;
  const Normalizer& obs_normalizer() const;
  const Normalizer& action_normalizer() const;
  /// Sets both normalisers (sizes must match obs_dim and action_dim).
  void set_normalizers(Normalizer obs, Normalizer action);

  /// Re-initialises the network (weights drawn from `seed`), keeping config and normalisers: an update
  /// that trains from scratch.
  void reinitialize(uint64_t seed);
  /// Which weights expected_loss, expected_losses and decide score with (sampling always uses the EMA).
  void set_score_weights(ScoreWeights w);
  ScoreWeights score_weights() const;
  /// The space every expected loss of this policy is measured in (default: the training target's).
  void set_score_space(ScoreSpace s);
  ScoreSpace score_space() const;
  /// The expected loss draws its timesteps from [0, k) instead of all T_d (the low-noise ones: their
  /// loss separates out-of-distribution states from multi-modal in-distribution ones, where the
  /// high-noise terms cost the spread between modes; results/fig2/low_noise_score.md). 0 or T_d:
  /// every timestep (the paper's score). Throws Error outside [0, T_d]. score_timesteps() returns
  /// the number drawn from.
  void set_score_timesteps(int k);
  int score_timesteps() const;
  /// Inference arithmetic for sample, decide and the expected losses (default float32). bfloat16
  /// throws Error in a build without oneDNN.
  void set_inference_precision(InferencePrecision p);
  InferencePrecision inference_precision() const;

  /// Generates one action chunk for `obs` (obs_dim) -> (T_p x action_dim), raw units.
  Mat sample(const Vec& obs, uint64_t seed) const;
  /// Generates one chunk per row of `obs` (B x obs_dim) -> B chunks.
  std::vector<Mat> sample_batch(const Mat& obs, uint64_t seed) const;

  /// Expected diffusion loss (eq. 2) of (obs, chunk): mean over n_samples rows of fresh noise with
  /// timesteps stratified as i mod T_d, in one batched forward pass.
  float expected_loss(const Vec& obs, const Mat& chunk, uint64_t seed,
                      int n_samples = kDefaultLossSamples) const;
  /// Expected loss of every pair of a data set (for threshold calibration), with progress.
  std::vector<float> expected_losses(const ChunkDataset& data, uint64_t seed,
                                     int n_samples = kDefaultLossSamples,
                                     const ProgressFn& progress = {}) const;
  /// The alpha-quantile (sorted[floor(n * alpha)]) of the expected losses of every pair of `data`.
  /// With `screen`, every pair is first scored with an eighth of the rows (whole timestep strata),
  /// and only the pairs that could lie above the quantile are scored with all n_samples: the same
  /// order statistic at a fraction of the cost (see LossQuantile). Progress runs over both passes.
  LossQuantile loss_quantile(const ChunkDataset& data, double alpha, uint64_t seed,
                             int n_samples = kDefaultLossSamples, bool screen = true,
                             const ProgressFn& progress = {}) const;
  /// The expected loss of (obs, chunk) per diffusion timestep: T_d means, each over n_samples / T_d
  /// rows of fresh noise (n_samples a multiple of T_d); their mean is expected_loss() with the same
  /// seed. For asking where along t two kinds of states separate.
  std::vector<float> loss_by_timestep(const Vec& obs, const Mat& chunk, uint64_t seed, int n_samples = kDefaultLossSamples) const;
  /// The same in each of `spaces`, from one pass of the network: element i equals loss_by_timestep()
  /// with the score space set to spaces[i] and the same seed.
  std::vector<std::vector<float>> loss_by_timestep(const Vec& obs, const Mat& chunk, uint64_t seed, int n_samples,
                                                   const std::vector<ScoreSpace>& spaces) const;
  /// Sampling plus expected loss of the sampled chunk: what the robot does at every decision.
  Decision decide(const Vec& obs, uint64_t seed, int n_samples = kDefaultLossSamples) const;
  /// The same, with the chunk's loss also measured in each of `also` (Decision::also): the same
  /// noise, the same timesteps and the same pass of the network, so `loss` and `chunk` equal the
  /// plain decide()'s and each extra space costs only its conversion.
  Decision decide(const Vec& obs, uint64_t seed, int n_samples, const std::vector<ScoreSpace>& also) const;
  /// decide() for a gate with this threshold: the same chunk (the same sampling), and its loss screened
  /// as loss_quantile screens pairs. The first rows are an eighth of n_samples (whole timestep strata);
  /// while their mean plus LossQuantile::kScreenZ standard errors reaches `threshold`, as many rows
  /// again are scored, up to n_samples in all. A loss that stops early lies kScreenZ standard errors
  /// below the threshold, so the verdict (loss > threshold) is the one n_samples rows give; only its
  /// value is the coarser estimate (Decision::rows says over how many rows). With n_samples not a
  /// multiple of the strata, or screening not worth it (as in loss_quantile), all rows at once.
  Decision decide_screened(const Vec& obs, uint64_t seed, int n_samples, float threshold) const;

  /// Writes config, normalisers, weights and EMA weights to one file (atomically: temp file + rename).
  /// Throws Error naming the file on failure; an existing checkpoint is left intact.
  void save(const std::string& path) const;
  /// The bytes save() would write, made in memory (named alike in every process): what the policy
  /// holds, as a fingerprint (PolicyEnsemble's training cache keys on it).
  std::string checkpoint_bytes() const;
  /// Loads a checkpoint into this policy. Throws Error naming the file and every config field that
  /// differs, or the file as truncated / corrupt.
  void load(const std::string& path);
  /// Builds a policy from a checkpoint's own config.
  static std::unique_ptr<DiffusionPolicy> from_checkpoint(const std::string& path);

  struct Impl;
  Impl& impl() { return *impl_; }
  const Impl& impl() const { return *impl_; }

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace dd
