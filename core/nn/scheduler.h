// The diffusion noise schedule (squaredcos_cap_v2 betas) and the DDPM / DDIM reverse steps.
// Internal to core: includes torch. Tensors are (B, T_p, A) action chunks; t is (B) int64.
#pragma once

#include <torch/torch.h>

#include <vector>

#include "core/config.h"

namespace dd::nn {

class NoiseScheduler {
 public:
  explicit NoiseScheduler(const SchedulerConfig& config);

  const SchedulerConfig& config() const { return config_; }
  int num_train_timesteps() const { return config_.num_train_timesteps; }
  const torch::Tensor& betas() const { return betas_; }                    // (T_d) float64
  const torch::Tensor& alphas_cumprod() const { return alphas_cumprod_; }  // (T_d) float64

  /// x_t = sqrt(abar_t) x0 + sqrt(1 - abar_t) eps.
  torch::Tensor add_noise(const torch::Tensor& x0, const torch::Tensor& eps, const torch::Tensor& t) const;
  /// v = sqrt(abar_t) eps - sqrt(1 - abar_t) x0.
  torch::Tensor velocity(const torch::Tensor& x0, const torch::Tensor& eps, const torch::Tensor& t) const;
  /// What the network is trained to output for (x0, eps, t) under the configured prediction type.
  torch::Tensor target(const torch::Tensor& x0, const torch::Tensor& eps, const torch::Tensor& t) const;
  /// Recovers x0 from a network output at x_t.
  torch::Tensor predicted_x0(const torch::Tensor& output, const torch::Tensor& x_t, const torch::Tensor& t) const;
  /// Recovers eps from a network output at x_t.
  torch::Tensor predicted_eps(const torch::Tensor& output, const torch::Tensor& x_t, const torch::Tensor& t) const;

  /// The timesteps a sampler visits, from T_d - 1 down to 0, num_inference_steps of them.
  std::vector<int64_t> inference_timesteps() const;
  /// One reverse step from timestep t to the next visited one; DDPM adds noise from `gen`.
  torch::Tensor step(const torch::Tensor& output, int64_t t, const torch::Tensor& x_t,
                     torch::Generator& gen) const;
  /// The same step on n raw floats in place: x_t becomes x_prev. noise (n values) is the DDPM step's
  /// standard normal draw, unused by DDIM and at t = 0 (pass nullptr there).
  void step(const float* output, int64_t t, float* x, size_t n, const float* noise) const;
  /// Whether step(t) draws noise: DDPM above t = 0.
  bool step_draws_noise(int64_t t) const { return config_.sampler == SamplerType::kDdpm && t > 0; }

 private:
  // sqrt(abar_t) and sqrt(1 - abar_t) gathered at t, shaped to broadcast against x.
  std::pair<torch::Tensor, torch::Tensor> coefficients(const torch::Tensor& t, const torch::Tensor& x) const;
  double abar(int64_t t) const { return t < 0 ? 1.0 : abar_cpu_[static_cast<size_t>(t)]; }

  SchedulerConfig config_;
  torch::Tensor betas_, alphas_cumprod_;
  torch::Tensor sqrt_abar_, sqrt_one_minus_abar_;  // float32 (T_d)
  std::vector<double> abar_cpu_;
};

}  // namespace dd::nn
