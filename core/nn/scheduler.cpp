#include "core/nn/scheduler.h"

#include <algorithm>

#include <cmath>

namespace dd::nn {
namespace {

// The "squaredcos_cap_v2" schedule: abar(s) = cos^2(((s + 0.008) / 1.008) * pi / 2),
// beta_i = min(1 - abar((i + 1) / T) / abar(i / T), 0.999).
std::vector<double> cosine_betas(int steps) {
  auto abar = [](double s) {
    const double c = std::cos((s + 0.008) / 1.008 * M_PI / 2.0);
    return c * c;
  };
  std::vector<double> betas(static_cast<size_t>(steps));
  for (int i = 0; i < steps; ++i) {
    const double t1 = static_cast<double>(i) / steps, t2 = static_cast<double>(i + 1) / steps;
    betas[static_cast<size_t>(i)] = std::min(1.0 - abar(t2) / abar(t1), 0.999);
  }
  return betas;
}

}  // namespace

NoiseScheduler::NoiseScheduler(const SchedulerConfig& config) : config_(config) {
  const std::vector<double> betas = cosine_betas(config.num_train_timesteps);
  abar_cpu_.resize(betas.size());
  double prod = 1.0;
  for (size_t i = 0; i < betas.size(); ++i) abar_cpu_[i] = prod *= (1.0 - betas[i]);
  const auto f64 = torch::TensorOptions().dtype(torch::kFloat64);
  betas_ = torch::tensor(betas, f64);
  alphas_cumprod_ = torch::tensor(abar_cpu_, f64);
  sqrt_abar_ = alphas_cumprod_.sqrt().to(torch::kFloat32);
  sqrt_one_minus_abar_ = (1.0 - alphas_cumprod_).sqrt().to(torch::kFloat32);
}

std::pair<torch::Tensor, torch::Tensor> NoiseScheduler::coefficients(const torch::Tensor& t,
                                                                     const torch::Tensor& x) const {
  std::vector<int64_t> shape(static_cast<size_t>(x.dim()), 1);
  shape[0] = t.size(0);
  return {sqrt_abar_.index_select(0, t).view(shape), sqrt_one_minus_abar_.index_select(0, t).view(shape)};
}

torch::Tensor NoiseScheduler::add_noise(const torch::Tensor& x0, const torch::Tensor& eps,
                                        const torch::Tensor& t) const {
  auto [a, s] = coefficients(t, x0);
  return a * x0 + s * eps;
}

torch::Tensor NoiseScheduler::velocity(const torch::Tensor& x0, const torch::Tensor& eps,
                                       const torch::Tensor& t) const {
  auto [a, s] = coefficients(t, x0);
  return a * eps - s * x0;
}

torch::Tensor NoiseScheduler::target(const torch::Tensor& x0, const torch::Tensor& eps,
                                     const torch::Tensor& t) const {
  switch (config_.prediction) {
    case PredictionType::kEpsilon: return eps;
    case PredictionType::kSample: return x0;
    case PredictionType::kVelocity: return velocity(x0, eps, t);
  }
  return {};
}

torch::Tensor NoiseScheduler::predicted_x0(const torch::Tensor& output, const torch::Tensor& x_t,
                                           const torch::Tensor& t) const {
  auto [a, s] = coefficients(t, x_t);
  switch (config_.prediction) {
    case PredictionType::kEpsilon: return (x_t - s * output) / a;
    case PredictionType::kSample: return output;
    case PredictionType::kVelocity: return a * x_t - s * output;
  }
  return {};
}

torch::Tensor NoiseScheduler::predicted_eps(const torch::Tensor& output, const torch::Tensor& x_t,
                                            const torch::Tensor& t) const {
  auto [a, s] = coefficients(t, x_t);
  switch (config_.prediction) {
    case PredictionType::kEpsilon: return output;
    case PredictionType::kSample: return (x_t - a * output) / s;
    case PredictionType::kVelocity: return s * x_t + a * output;
  }
  return {};
}

std::vector<int64_t> NoiseScheduler::inference_timesteps() const {
  const int n = config_.num_inference_steps, T = config_.num_train_timesteps;
  std::vector<int64_t> ts;
  ts.reserve(static_cast<size_t>(n));
  for (int i = n - 1; i >= 0; --i) ts.push_back(static_cast<int64_t>(i) * T / n);
  return ts;
}

torch::Tensor NoiseScheduler::step(const torch::Tensor& output, int64_t t, const torch::Tensor& x_t,
                                   torch::Generator& gen) const {
  // The scalar step on a float copy; DDPM's draw has x_t's shape, as the posterior's noise.
  const torch::Tensor out = output.to(torch::kFloat32).contiguous();
  torch::Tensor x = x_t.to(torch::kFloat32).contiguous().clone();
  const torch::Tensor noise = step_draws_noise(t) ? torch::randn(x.sizes(), gen, x.options()) : torch::Tensor();
  step(out.data_ptr<float>(), t, x.data_ptr<float>(), static_cast<size_t>(x.numel()), noise.defined() ? noise.data_ptr<float>() : nullptr);
  return x;
}

// x0 from the network output with scalar coefficients (one timestep for the whole batch), clipped;
// then DDIM (eta = 0, eps re-derived from the clipped x0) or the DDPM posterior q(x_prev | x_t, x0)
// with the "fixed small" variance.
void NoiseScheduler::step(const float* output, int64_t t, float* x, size_t n, const float* noise) const {
  const int64_t prev = t - config_.num_train_timesteps / config_.num_inference_steps;
  const double ab_t = abar(t), ab_prev = abar(prev);
  const auto a = static_cast<float>(std::sqrt(ab_t)), s = static_cast<float>(std::sqrt(1.0 - ab_t));
  const double alpha_t = ab_t / ab_prev, beta_t = 1.0 - alpha_t;
  const bool ddim = config_.sampler == SamplerType::kDdim;
  // DDIM: sqrt(abar_prev) x0 + sqrt(1 - abar_prev) eps; DDPM: the posterior mean plus noise.
  const auto c_x0 = static_cast<float>(ddim ? std::sqrt(ab_prev) : std::sqrt(ab_prev) * beta_t / (1.0 - ab_t));
  const auto c_xt = static_cast<float>(std::sqrt(alpha_t) * (1.0 - ab_prev) / (1.0 - ab_t));
  const auto c_eps = static_cast<float>(std::sqrt(1.0 - ab_prev));
  const auto sd = static_cast<float>(std::sqrt(std::max((1.0 - ab_prev) / (1.0 - ab_t) * beta_t, 1e-20)));
  const bool draws = step_draws_noise(t);
  for (size_t i = 0; i < n; ++i) {
    float x0 = 0;
    switch (config_.prediction) {
      case PredictionType::kEpsilon: x0 = (x[i] - s * output[i]) / a; break;
      case PredictionType::kSample: x0 = output[i]; break;
      case PredictionType::kVelocity: x0 = a * x[i] - s * output[i]; break;
    }
    if (config_.clip_sample) x0 = std::clamp(x0, -1.f, 1.f);
    if (ddim) {
      x[i] = c_x0 * x0 + c_eps * ((x[i] - a * x0) / s);
    } else {
      x[i] = x0 * c_x0 + c_xt * x[i] + (draws ? sd * noise[i] : 0.f);
    }
  }
}

}  // namespace dd::nn
