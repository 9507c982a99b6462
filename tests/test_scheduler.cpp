// Scheduler algebra: the squaredcos_cap_v2 schedule, conversions between prediction targets, and
// reverse chains driven by an ideal predictor.
#include <gtest/gtest.h>

#include "core/nn/scheduler.h"

namespace dd::nn {
namespace {

SchedulerConfig config_for(PredictionType p, SamplerType s = SamplerType::kDdpm, int steps = 16) {
  SchedulerConfig c;
  c.prediction = p;
  c.sampler = s;
  c.num_train_timesteps = steps;
  c.num_inference_steps = steps;
  return c;
}

// A predictor that knows the clean sample x0 and outputs the exact target at x_t.
torch::Tensor oracle(const NoiseScheduler& s, const torch::Tensor& x0, const torch::Tensor& x_t, int64_t t) {
  const torch::Tensor tt = torch::full({x_t.size(0)}, t, torch::kInt64);
  const double ab = s.alphas_cumprod()[t].item<double>();
  const torch::Tensor eps = (x_t - std::sqrt(ab) * x0) / std::sqrt(1.0 - ab);
  return s.target(x0, eps, tt);
}

}  // namespace

TEST(Scheduler, CosineScheduleIsMonotoneAndCapped) {
  NoiseScheduler s(config_for(PredictionType::kVelocity));
  const torch::Tensor b = s.betas(), ab = s.alphas_cumprod();
  EXPECT_TRUE((b > 0).all().item<bool>());
  EXPECT_LE(b.max().item<double>(), 0.999 + 1e-12);
  EXPECT_TRUE((ab.slice(0, 1) < ab.slice(0, 0, -1)).all().item<bool>());
  EXPECT_GT(ab[0].item<double>(), 0.95);  // barely noised at t = 0
  EXPECT_LT(ab[-1].item<double>(), 1e-3); // nearly pure noise at t = T_d - 1
}

TEST(Scheduler, PredictionConversionsRoundTrip) {
  torch::manual_seed(0);
  const torch::Tensor x0 = torch::rand({16, 8, 3}) * 2 - 1;
  const torch::Tensor eps = torch::randn({16, 8, 3});
  const torch::Tensor t = torch::arange(16, torch::kInt64);
  for (PredictionType p : {PredictionType::kEpsilon, PredictionType::kSample, PredictionType::kVelocity}) {
    NoiseScheduler s(config_for(p));
    const torch::Tensor x_t = s.add_noise(x0, eps, t);
    const torch::Tensor out = s.target(x0, eps, t);
    EXPECT_TRUE(torch::allclose(s.predicted_x0(out, x_t, t), x0, 1e-3, 1e-3)) << to_string(p);
    // eps from a sample prediction divides by sqrt(1 - abar) which is ~0.02 at t = 0: looser there.
    EXPECT_TRUE(torch::allclose(s.predicted_eps(out, x_t, t), eps, 1e-3, 5e-3)) << to_string(p);
  }
}

TEST(Scheduler, VelocityMatchesItsDefinition) {
  NoiseScheduler s(config_for(PredictionType::kVelocity));
  const torch::Tensor x0 = torch::ones({1, 2, 1}), eps = torch::full({1, 2, 1}, 2.0);
  const int64_t t = 5;
  const double ab = s.alphas_cumprod()[t].item<double>();
  const torch::Tensor v = s.velocity(x0, eps, torch::full({1}, t, torch::kInt64));
  EXPECT_NEAR(v[0][0][0].item<double>(), std::sqrt(ab) * 2.0 - std::sqrt(1 - ab) * 1.0, 1e-6);
}

TEST(Scheduler, IdealPredictorChainsRecoverTheSample) {
  const torch::Tensor x0 = torch::linspace(-0.9, 0.9, 24).view({2, 6, 2});
  for (SamplerType sampler : {SamplerType::kDdpm, SamplerType::kDdim}) {
    for (PredictionType p : {PredictionType::kEpsilon, PredictionType::kSample, PredictionType::kVelocity}) {
      NoiseScheduler s(config_for(p, sampler));
      torch::Generator gen = at::detail::createCPUGenerator(1);
      torch::Tensor x = torch::randn(x0.sizes(), gen, torch::kFloat32);
      for (int64_t t : s.inference_timesteps()) x = s.step(oracle(s, x0, x, t), t, x, gen);
      EXPECT_TRUE(torch::allclose(x, x0, 1e-4, 1e-4)) << to_string(sampler) << " " << to_string(p);
    }
  }
}

TEST(Scheduler, InferenceTimestepsStrideDownToZero) {
  SchedulerConfig c = config_for(PredictionType::kVelocity, SamplerType::kDdim, 16);
  c.num_inference_steps = 4;
  NoiseScheduler s(c);
  EXPECT_EQ(s.inference_timesteps(), (std::vector<int64_t>{12, 8, 4, 0}));
}

}  // namespace dd::nn
