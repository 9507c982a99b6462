// The 1-D temporal U-Net over an action chunk, FiLM-conditioned on a global condition
// (observation features ++ diffusion-step embedding). Internal to core: includes torch.
//
// The FiLM terms depend only on (observation, timestep), so the forward pass is split in two:
// film() computes every residual block's scale and bias from the condition, and denoise() runs the
// convolutions. The expected loss uses this to condition T_d distinct rows and gather them for
// its N_b rows instead of conditioning all N_b.
#pragma once

#include <torch/torch.h>

#include <vector>

#include "core/config.h"

namespace dd::nn {

class FastDenoiser;

/// Conv1d -> GroupNorm -> Mish.
struct Conv1dBlockImpl : torch::nn::Module {
  Conv1dBlockImpl(int in, int out, int kernel, int groups);
  torch::Tensor forward(const torch::Tensor& x);  // (B, in, T) -> (B, out, T)
  torch::nn::Conv1d conv{nullptr};
  torch::nn::GroupNorm norm{nullptr};
};
TORCH_MODULE(Conv1dBlock);

/// Two Conv1dBlocks with a FiLM modulation (scale, bias per channel) between them and a residual path.
struct ResBlockImpl : torch::nn::Module {
  ResBlockImpl(int in, int out, int cond_dim, int kernel, int groups);
  /// (B, cond_dim) -> (B, 2 * out): per-channel scale then bias.
  torch::Tensor film(const torch::Tensor& cond);
  /// x: (B, in, T), film: (B, 2 * out) -> (B, out, T).
  torch::Tensor forward(const torch::Tensor& x, const torch::Tensor& film);
  int out_channels;
  Conv1dBlock block0{nullptr}, block1{nullptr};
  torch::nn::Linear film_proj{nullptr};
  torch::nn::Conv1d residual{nullptr};  // 1x1 when in != out, else empty
};
TORCH_MODULE(ResBlock);

/// ConditionalUnet1D.
class ConditionalUnet1DImpl : public torch::nn::Module {
 public:
  /// action_dim channels in and out; global_cond_dim = obs_dim * T_o.
  ConditionalUnet1DImpl(int action_dim, int global_cond_dim, const UnetConfig& config);

  /// Condition rows: (B) int64 timesteps and (B, global_cond_dim) -> (B, cond_dim).
  torch::Tensor condition(const torch::Tensor& t, const torch::Tensor& global_cond);
  /// Every residual block's FiLM output for condition rows, in forward order.
  std::vector<torch::Tensor> film(const torch::Tensor& cond);
  /// Network output for noisy chunks x: (B, T_p, A) given per-row FiLM terms -> (B, T_p, A).
  torch::Tensor denoise(const torch::Tensor& x, const std::vector<torch::Tensor>& films);
  /// The whole forward pass: x (B, T_p, A), t (B), global_cond (B, G) -> (B, T_p, A).
  torch::Tensor forward(const torch::Tensor& x, const torch::Tensor& t, const torch::Tensor& global_cond);

 private:
  friend class FastDenoiser;  // reads the layers in place (core/nn/fast_unet.h)
  struct Level {
    ResBlock first{nullptr}, second{nullptr};
    torch::nn::Conv1d down{nullptr};            // stride-2 downsampling, empty on the last level
    torch::nn::ConvTranspose1d up{nullptr};     // stride-2 upsampling (up levels only)
  };
  ResBlock add_res(const std::string& name, int in, int out);

  UnetConfig config_;
  int cond_dim_;
  torch::nn::Linear step_fc1{nullptr}, step_fc2{nullptr};
  std::vector<Level> down_, up_;
  ResBlock mid0_{nullptr}, mid1_{nullptr};
  Conv1dBlock final_block_{nullptr};
  torch::nn::Conv1d final_conv_{nullptr};
  std::vector<ResBlock> all_res_;  // every ResBlock in forward order, for film()
};
TORCH_MODULE(ConditionalUnet1D);

/// A ConvTranspose1d's output computed as an ordinary convolution where its options allow (kernel 4,
/// stride 2, padding 1: the U-Net's upsampling), else its own forward.
torch::Tensor upsample(torch::nn::ConvTranspose1dImpl& up, const torch::Tensor& x);

/// How many parameters ConditionalUnet1D(action_dim, global_cond_dim, config) has, counted without
/// building it (a corrupt checkpoint's config may describe terabytes). Within PolicyConfig's bounds
/// it fits int64; tests/test_checkpoint.cpp checks it against built networks.
int64_t parameter_count(int action_dim, int global_cond_dim, const UnetConfig& config);

/// Sinusoidal embedding of diffusion timesteps: (B) -> (B, dim).
torch::Tensor sinusoidal_embedding(const torch::Tensor& t, int dim);

}  // namespace dd::nn
