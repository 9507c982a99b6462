#include "core/trainer.h"

#include <chrono>
#include <cmath>

#include "core/chunks.h"
#include "core/nn/policy_impl.h"

namespace dd {

double TrainStats::first_mean(int window) const {
  const size_t n = std::min(losses.size(), static_cast<size_t>(window));
  double s = 0;
  for (size_t i = 0; i < n; ++i) s += losses[i];
  return n ? s / n : NAN;
}

double TrainStats::last_mean(int window) const {
  const size_t n = std::min(losses.size(), static_cast<size_t>(window));
  double s = 0;
  for (size_t i = losses.size() - n; i < losses.size(); ++i) s += losses[i];
  return n ? s / n : NAN;
}

double scheduled_lr(const TrainConfig& c, int step, int total) {
  if (step < c.warmup_steps) return c.lr * (step + 1) / c.warmup_steps;
  const double span = std::max(1, total - c.warmup_steps);
  const double progress = std::min(1.0, (step - c.warmup_steps) / span);
  return c.lr * 0.5 * (1.0 + std::cos(M_PI * progress));
}

TrainStats train(DiffusionPolicy& policy, const ChunkDataset& data, const TrainConfig& config,
                 const ProgressFn& progress) {
  config.validate();
  auto& impl = policy.impl();
  const PolicyConfig& pc = impl.config;
  if (data.size() == 0) throw Error("train: the data set is empty");
  if (data.obs_dim() != pc.obs_dim || data.action_dim != pc.action_dim || data.horizon != pc.horizon)
    throw Error("train: data set shapes (obs " + std::to_string(data.obs_dim()) + ", action " +
                std::to_string(data.action_dim) + ", horizon " + std::to_string(data.horizon) +
                ") do not match the policy config");
  if (config.fit_normalizer) policy.set_normalizers(Normalizer::fit(data.obs), Normalizer::fit(data.action_rows()));

  const torch::Tensor obs = impl.obs_tensor(data.obs);
  const torch::Tensor chunks = impl.chunk_tensor(data.chunks);
  torch::Generator gen = make_generator(config.seed);

  auto params = impl.model->parameters();
  torch::optim::AdamW opt(params, torch::optim::AdamWOptions(config.lr)
                                      .betas({config.beta1, config.beta2})
                                      .weight_decay(config.weight_decay));
  impl.model->train();
  impl.copy_model_to_ema();
  std::vector<torch::Tensor> ema_params = impl.ema->parameters();

  TrainStats stats;
  stats.losses.reserve(static_cast<size_t>(config.steps));
  const auto start = std::chrono::steady_clock::now();
  const int64_t T = pc.scheduler.num_train_timesteps;
  for (int step = 0; step < config.steps; ++step) {
    const torch::Tensor idx = torch::randint(data.size(), {config.batch_size}, gen, torch::kInt64);
    const torch::Tensor o = obs.index_select(0, idx);
    const torch::Tensor x0 = chunks.index_select(0, idx);
    const torch::Tensor eps = torch::randn(x0.sizes(), gen, x0.options());
    const torch::Tensor t = torch::randint(T, {config.batch_size}, gen, torch::kInt64);
    const torch::Tensor pred = impl.model->forward(impl.scheduler.add_noise(x0, eps, t), t, o);
    const torch::Tensor loss = torch::mse_loss(pred, impl.scheduler.target(x0, eps, t));

    opt.zero_grad();
    loss.backward();
    if (config.grad_clip > 0) torch::nn::utils::clip_grad_norm_(params, config.grad_clip);
    for (auto& group : opt.param_groups()) group.options().set_lr(scheduled_lr(config, step, config.steps));
    opt.step();

    {  // EMA with warm-up: decay = 1 - (1 + step)^-power, capped; the first update copies.
      torch::NoGradGuard no_grad;
      const double decay = std::min(config.ema_max_decay, 1.0 - std::pow(1.0 + step, -config.ema_power));
      torch::_foreach_mul_(ema_params, decay);
      torch::_foreach_add_(ema_params, params, 1.0 - decay);
    }
    const float l = loss.item<float>();
    if (!std::isfinite(l)) throw Error("train: the loss became non-finite at step " + std::to_string(step));
    stats.losses.push_back(l);
    if (progress) progress(step + 1, config.steps, stats.last_mean(20));
  }
  impl.model->eval();
  stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return stats;
}

}  // namespace dd
