// DiffusionPolicy's internals, shared by policy.cpp, trainer.cpp and checkpoint.cpp. Includes torch.
#pragma once

#include <torch/torch.h>

#include <atomic>
#include <memory>
#include <mutex>

#include "core/nn/fast_unet.h"
#include "core/nn/scheduler.h"
#include "core/nn/unet.h"
#include "core/policy.h"

namespace dd {

struct DiffusionPolicy::Impl {
  Impl(const PolicyConfig& c, uint64_t seed);

  PolicyConfig config;
  nn::ConditionalUnet1D model{nullptr};  // trained weights
  // Exponential moving average of the weights, used for sampling and losses. Mutable: torch modules
  // have no const forward, and inference does not change them.
  mutable nn::ConditionalUnet1D ema{nullptr};
  ScoreWeights score_weights = ScoreWeights::kEma;
  ScoreSpace score_space = ScoreSpace::kTarget;
  int score_timesteps = 0;  // the score draws t from [0, this); 0: every timestep (set_score_timesteps)
  /// The number of timesteps the score draws from: score_timesteps, or T_d when it is 0.
  int scored_timesteps() const { return score_timesteps > 0 ? score_timesteps : config.scheduler.num_train_timesteps; }
  /// The network that scores the expected loss (a handle sharing the module).
  nn::ConditionalUnet1D scorer() const { return score_weights == ScoreWeights::kRaw ? model : ema; }
  nn::NoiseScheduler scheduler;
  Normalizer obs_norm, act_norm;

  /// Copies the live weights into the EMA network.
  void copy_model_to_ema();
  /// Normalised observations as a (B, obs_dim) tensor.
  torch::Tensor obs_tensor(const Mat& obs) const;
  /// Chunks as the model sees them, normalised: rows of (T_p * A) raw actions, each with the row of
  /// `obs` (raw) it was planned from -> (B, T_p, A).
  torch::Tensor chunk_tensor(const Mat& obs, const Mat& chunk_rows) const;
  /// Raw chunk rows made relative to their observations (config.relative_actions; unchanged without).
  Mat relative_chunks(const Mat& obs, const Mat& chunk_rows) const;
  /// A generated chunk (1, T_p, A) or (T_p, A), normalised, back to raw actions for its raw observation.
  Mat raw_chunk(const torch::Tensor& chunk, const Eigen::Ref<const Vec>& obs) const;
  /// Expected loss for B pairs: obs (B, obs_dim) and chunks (B, T_p, A), both normalised -> (B).
  torch::Tensor expected_loss(const torch::Tensor& obs, const torch::Tensor& chunks, int n_samples,
                              torch::Generator& gen) const;
  /// The same rows' losses one by one: (B, n_samples), row i at timestep i mod K (K: scored_timesteps()).
  torch::Tensor row_losses(const torch::Tensor& obs, const torch::Tensor& chunks, int n_samples,
                           torch::Generator& gen) const;
  /// The same rows scored in each of `spaces` from one pass of the network (the same noise), row i at
  /// timestep i mod `timesteps`.
  std::vector<torch::Tensor> row_losses(const torch::Tensor& obs, const torch::Tensor& chunks, int n_samples,
                                        torch::Generator& gen, const std::vector<ScoreSpace>& spaces, int timesteps) const;
  /// Reverse diffusion from noise for normalised obs (B, obs_dim) -> normalised chunks (B, T_p, A).
  /// The conditioning of every (row, timestep) is computed in one pass before the denoising loop.
  torch::Tensor sample(const torch::Tensor& obs, torch::Generator& gen) const;
  /// sample() runs the denoising passes of small batches on nn::FastDenoiser unless this is set (then on torch's
  /// operators, as before it existed: the benchmarks' baseline). expected_loss() stays on torch's.
  bool torch_denoise = false;
  /// In float32, sample() uses FastDenoiser below this many rows only (torch's passes from there on).
  static constexpr int64_t kFastSampleMaxRows = 16;
  /// Inference arithmetic (set_inference_precision). With bfloat16, expected_loss() runs its
  /// denoising pass on nn::FastDenoiser too.
  InferencePrecision precision = InferencePrecision::kFloat32;
  nn::Precision fast_precision() const {
    return precision == InferencePrecision::kBFloat16 ? nn::Precision::kBFloat16 : nn::Precision::kFloat32;
  }
  /// A FastDenoiser over `net` (ema, or model when it scores) in this policy's precision, kept while
  /// the weights stay as they are: in bfloat16 it holds every weight converted, which costs a few
  /// milliseconds at 64,128,256, as much as a batch-1 sample. Whatever changes the weights in place
  /// (a training step, loading weights, copying model to ema) calls weights_changed(); the cache
  /// also checks the weights' storage, which a trainer moves into its flat buffers.
  std::shared_ptr<const nn::FastDenoiser> fast_denoiser(const nn::ConditionalUnet1DImpl& net) const;
  void weights_changed() { ++weights_version_; }

  /// The same computation with the full forward pass at every step (the reference for tests).
  torch::Tensor sample_reference(const torch::Tensor& obs, torch::Generator& gen) const;

 private:
  std::atomic<uint64_t> weights_version_{0};
  struct FastKey {
    const void* net = nullptr;
    const void* first_weight = nullptr;
    uint64_t version = 0;
    InferencePrecision precision = InferencePrecision::kFloat32;
    bool operator==(const FastKey& o) const {
      return net == o.net && first_weight == o.first_weight && version == o.version && precision == o.precision;
    }
  };
  struct FastSlot {
    std::shared_ptr<const nn::FastDenoiser> denoiser;
    FastKey key;
  };
  mutable std::mutex fast_mutex_;
  mutable FastSlot fast_[2];  // [0]: ema, [1]: model
};

/// A CPU generator seeded with `seed`.
torch::Generator make_generator(uint64_t seed);

}  // namespace dd
