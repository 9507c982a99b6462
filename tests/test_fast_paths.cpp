// The fast inference paths compute what the reference paths compute: sampling with the conditioning
// hoisted out of the denoising loop and the denoising passes on FastDenoiser, and the scheduler's
// scalar step against its tensor formulas.
#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include "core/chunks.h"
#include "core/ensemble.h"
#include "core/gate.h"
#include "core/isolate.h"
#include "core/synthetic.h"
#include "core/trainer.h"
#include "core/nn/bf16_gemm.h"
#include "core/nn/fast_unet.h"
#include "core/nn/mish.h"
#include "core/nn/policy_impl.h"
#include "core/runtime.h"

namespace dd {

// A small policy config: 5 observation and 3 action features, chunks of 16, the named U-Net.
PolicyConfig small_config(const std::string& unet) {
  PolicyConfig c;
  c.obs_dim = 5;
  c.action_dim = 3;
  c.horizon = 16;
  c.unet = unet_preset(unet);
  return c;
}


TEST(FastPaths, HoistedConditioningSamplesMatchTheFullForwardPass) {
  for (PredictionType p : {PredictionType::kVelocity, PredictionType::kEpsilon, PredictionType::kSample}) {
    for (SamplerType s : {SamplerType::kDdpm, SamplerType::kDdim}) {
      PolicyConfig c;
      c.obs_dim = 5;
      c.action_dim = 3;
      c.horizon = 8;
      c.unet = unet_preset("tiny");
      c.scheduler.prediction = p;
      c.scheduler.sampler = s;
      DiffusionPolicy policy(c, 7, false);
      // 3 rows run on FastDenoiser, kFastSampleMaxRows rows on torch's passes
      for (int64_t rows : {int64_t{3}, DiffusionPolicy::Impl::kFastSampleMaxRows}) {
        const torch::Tensor obs = torch::rand({rows, 5}) * 2 - 1;
        torch::Generator g1 = make_generator(11), g2 = make_generator(11);
        const torch::Tensor fast = policy.impl().sample(obs, g1);
        const torch::Tensor ref = policy.impl().sample_reference(obs, g2);
        EXPECT_TRUE(torch::allclose(fast, ref, 1e-4, 1e-4)) << to_string(p) << " " << to_string(s) << " rows " << rows
                                                            << " max diff " << (fast - ref).abs().max().item<float>();
      }
    }
  }
}

// The task presets' shapes: horizons 16, 32 and 64, down_dims 16,32,64, 32,64,128 and 64,128,256, perturbed
// weights rather than fresh ones (GroupNorm's affine terms and biases away from their defaults).
TEST(FastPaths, FastDenoiserMatchesTorchsDenoisingPass) {
  struct Shape {
    int obs, act, horizon;
    std::string unet;
    int kernel = 5;
  };
  // and kernels wider than the chunk at every level (T_p 4, then 2), where the padding is most of
  // each convolution's input: checkpoints the fuzzer wrote reach such shapes
  for (const Shape& shape : {Shape{24, 7, 32, "cpu"}, Shape{37, 10, 64, "cpu"}, Shape{4, 2, 16, "medium"}, Shape{5, 3, 8, "tiny"},
                             Shape{4, 2, 4, "8,8", 9}, Shape{4, 2, 4, "8,8", 63}}) {
    PolicyConfig c;
    c.obs_dim = shape.obs;
    c.action_dim = shape.act;
    c.horizon = shape.horizon;
    c.action_steps = std::min(c.action_steps, c.horizon);
    if (shape.unet == "8,8") {
      c.unet.down_dims = {8, 8};
      c.unet.n_groups = 4;
    } else {
      c.unet = unet_preset(shape.unet);
    }
    c.unet.kernel_size = shape.kernel;
    DiffusionPolicy policy(c, 5, false);
    auto& net = *policy.impl().ema;
    torch::manual_seed(9);
    {
      torch::NoGradGuard no_grad;
      for (auto& p : net.parameters()) p.add_(torch::randn_like(p) * 0.05);
    }
    // more rows than one block holds, so the blocks' seams are crossed
    const int64_t B = nn::FastDenoiser::kColumnsPerBlock / c.horizon + 5;
    const torch::Tensor x = torch::randn({B, c.horizon, c.action_dim});
    const torch::Tensor t = torch::arange(B, torch::kInt64) % 16;
    const torch::Tensor obs = torch::rand({B, c.obs_dim}) * 2 - 1;
    torch::NoGradGuard no_grad;
    const std::vector<torch::Tensor> films = net.film(net.condition(t, obs));
    const torch::Tensor ref = net.denoise(x, films);
    const torch::Tensor fast = nn::FastDenoiser(net).denoise(x, films);
    EXPECT_TRUE(torch::allclose(fast, ref, 1e-4, 1e-4))
        << shape.unet << " kernel " << shape.kernel << " T_p " << c.horizon << " max diff " << (fast - ref).abs().max().item<float>();
  }
}

constexpr const char* kNoBf16 = "no oneDNN bf16 matmul here (built without libdnnl-dev, or a CPU without AVX-512)";

// Where oneDNN has no bf16 matmul (a CPU without AVX-512), asking for bfloat16 is an Error that names
// the setting and the way out, and the policy keeps float32.
TEST(FastPaths, BFloat16IsRefusedByNameWhereItCannotRun) {
  if (nn::have_bf16_gemm()) GTEST_SKIP() << "bf16 matmul is available here";
  DiffusionPolicy policy(small_config("cpu"), 5, false);
  try {
    policy.set_inference_precision(InferencePrecision::kBFloat16);
    FAIL() << "bfloat16 accepted without a bf16 matmul";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("method.precision"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("float32"), std::string::npos) << e.what();
  }
  EXPECT_EQ(policy.inference_precision(), InferencePrecision::kFloat32);
}

// bfloat16 products (the option, not the default): close to float32 at the presets' shapes, and the
// expected losses of a trained policy keep their order (what the gate's threshold depends on).
TEST(FastPaths, BFloat16DenoiserStaysCloseToFloat32) {
  if (!nn::have_bf16_gemm()) GTEST_SKIP() << kNoBf16;
  for (const char* unet : {"cpu", "medium"}) {
    PolicyConfig c = small_config(unet);
    c.obs_dim = 24;
    c.action_dim = 7;
    c.horizon = 32;
    DiffusionPolicy policy(c, 5, false);
    auto& net = *policy.impl().ema;
    const int64_t B = 40;
    const torch::Tensor x = torch::randn({B, c.horizon, c.action_dim});
    const torch::Tensor obs = torch::rand({B, c.obs_dim}) * 2 - 1;
    torch::NoGradGuard no_grad;
    const std::vector<torch::Tensor> films = net.film(net.condition(torch::arange(B, torch::kInt64) % 16, obs));
    const torch::Tensor ref = nn::FastDenoiser(net).denoise(x, films);
    const torch::Tensor half = nn::FastDenoiser(net, nn::Precision::kBFloat16).denoise(x, films);
    const double rel = ((half - ref).norm() / ref.norm()).item<double>();
    EXPECT_LT(rel, 2e-2) << unet;
    EXPECT_GT(rel, 0.0) << unet << ": the bfloat16 path ran in float32";
  }
}

TEST(FastPaths, BFloat16ExpectedLossesKeepTheirOrder) {
  if (!nn::have_bf16_gemm()) GTEST_SKIP() << kNoBf16;
  const PolicyConfig c = small_config("tiny");
  DiffusionPolicy policy(c, 3, false);
  const ChunkDataset data = ChunkDataset::from_episodes(bimodal_episodes(8, 20, 5, 3, 2), c.horizon);
  TrainConfig t;
  t.steps = 80;
  t.batch_size = 32;
  train(policy, data, t);
  const std::vector<float> f32 = policy.expected_losses(data, 17, 64);
  policy.set_inference_precision(InferencePrecision::kBFloat16);
  EXPECT_EQ(policy.inference_precision(), InferencePrecision::kBFloat16);
  const std::vector<float> bf16 = policy.expected_losses(data, 17, 64);  // the same noise draws
  ASSERT_EQ(f32.size(), bf16.size());
  EXPECT_NE(f32, bf16) << "the same numbers: the bfloat16 path did not run";
  EXPECT_GT(spearman(f32, bf16), 0.95);
  // batch-1 sampling has too few columns for bfloat16 to pay (FastDenoiser::kBf16MinColumns): the
  // same chunk as float32 from the same noise
  const Vec o = data.obs.row(0).transpose();
  const Mat a = policy.sample(o, 5);
  policy.set_inference_precision(InferencePrecision::kFloat32);
  const Mat b = policy.sample(o, 5);
  EXPECT_TRUE(a.isApprox(b, 1e-6f));
  EXPECT_THROW(inference_precision_from("float16"), Error);
}

TEST(FastPaths, BFloat16WeightsAreConvertedAgainWhenTheWeightsChange) {
  if (!nn::have_bf16_gemm()) GTEST_SKIP() << kNoBf16;
  const PolicyConfig c = small_config("tiny");
  DiffusionPolicy policy(c, 3, false);
  policy.set_inference_precision(InferencePrecision::kBFloat16);
  const ChunkDataset data = ChunkDataset::from_episodes(bimodal_episodes(8, 20, 5, 3, 2), c.horizon);
  TrainConfig t;
  t.steps = 80;
  t.batch_size = 32;
  Trainer trainer(policy, data, t);  // one trainer: the weights change in place, in the same buffers
  for (int i = 0; i < 40; ++i) trainer.step();
  const std::vector<float> before = policy.expected_losses(data, 17, 64);  // converts and keeps the weights
  for (int i = 0; i < 40; ++i) trainer.step();
  const std::vector<float> after = policy.expected_losses(data, 17, 64);
  EXPECT_NE(before, after) << "training changed nothing, or the bfloat16 weights were stale";
  // the same weights loaded into a fresh policy, converted from scratch: the same numbers
  const std::string path = testing::TempDir() + "/bf16_cache.pt";
  policy.save(path);
  const auto loaded = DiffusionPolicy::from_checkpoint(path);
  loaded->set_inference_precision(InferencePrecision::kBFloat16);
  EXPECT_EQ(loaded->expected_losses(data, 17, 64), after);
  std::filesystem::remove(path);
}

// With score_weights raw, sampling reads the EMA weights and scoring the raw ones: each keeps its own
// converted copy, so a decision does not convert both again.
TEST(FastPaths, EmaAndRawWeightsKeepTheirOwnFastDenoiser) {
  const PolicyConfig c = small_config("tiny");
  DiffusionPolicy policy(c, 3, false);
  policy.set_score_weights(ScoreWeights::kRaw);
  auto& impl = policy.impl();
  const auto ema = impl.fast_denoiser(*impl.ema);
  const auto raw = impl.fast_denoiser(*impl.model);
  EXPECT_NE(ema.get(), raw.get());
  EXPECT_EQ(impl.fast_denoiser(*impl.ema).get(), ema.get());
  EXPECT_EQ(impl.fast_denoiser(*impl.model).get(), raw.get());
  impl.weights_changed();
  EXPECT_NE(impl.fast_denoiser(*impl.ema).get(), ema.get());
}

TEST(FastPaths, BFloat16BatchOneSamplingUsesItWhereTheWeightsAreMany) {
  if (!nn::have_bf16_gemm()) GTEST_SKIP() << kNoBf16;
  PolicyConfig c = small_config("medium");  // 64,128,256: middle blocks of 256 x 1280 weights
  DiffusionPolicy policy(c, 4, false);
  const Vec o = Vec::Constant(c.obs_dim, 0.3f);
  const Mat f32 = policy.sample(o, 9);
  policy.set_inference_precision(InferencePrecision::kBFloat16);
  const Mat bf16 = policy.sample(o, 9);
  EXPECT_FALSE(bf16.isApprox(f32, 1e-6f)) << "batch-1 sampling did not run in bfloat16";
  EXPECT_LT((bf16 - f32).norm() / f32.norm(), 5e-2);
}

TEST(FastPaths, FusedMishMatchesTorchsForwardAndGradient) {
  // across the exponential's range, and past the cap at 20 where both saturate
  const torch::Tensor base = torch::cat({torch::linspace(-40, 40, 4001), torch::randn({50000}) * 3});
  const torch::Tensor a = base.clone().requires_grad_(true), b = base.clone().requires_grad_(true);
  const torch::Tensor ya = nn::mish(a), yb = torch::mish(b);
  EXPECT_TRUE(torch::allclose(ya, yb, 1e-5, 1e-6)) << "max diff " << (ya - yb).abs().max().item<float>();
  const torch::Tensor g = torch::randn(base.sizes());
  ya.backward(g);
  yb.backward(g);
  EXPECT_TRUE(torch::allclose(a.grad(), b.grad(), 1e-4, 1e-5)) << "max diff " << (a.grad() - b.grad()).abs().max().item<float>();
  torch::NoGradGuard no_grad;  // inference takes the same kernel without autograd
  EXPECT_TRUE(torch::allclose(nn::mish(base), yb.detach(), 1e-5, 1e-6));
}

TEST(FastPaths, UpsamplingAsAConvolutionMatchesTheTransposedConvolution) {
  torch::manual_seed(5);
  torch::nn::ConvTranspose1d up(torch::nn::ConvTranspose1dOptions(12, 9, 4).stride(2).padding(1));
  for (int64_t T : {1, 2, 5, 8}) {
    const torch::Tensor a = torch::randn({3, 12, T}).requires_grad_(true), b = a.detach().clone().requires_grad_(true);
    const torch::Tensor ya = nn::upsample(*up, a), yb = up->forward(b);
    ASSERT_EQ(ya.sizes(), yb.sizes());
    EXPECT_TRUE(torch::allclose(ya, yb, 1e-5, 1e-5)) << "T " << T << " max diff " << (ya - yb).abs().max().item<float>();
    // and the gradients, for the input and the weights
    const torch::Tensor g = torch::randn(ya.sizes());
    up->zero_grad();
    ya.backward(g);
    const torch::Tensor wa = up->weight.grad().clone(), ba = up->bias.grad().clone();
    up->zero_grad();
    yb.backward(g);
    EXPECT_TRUE(torch::allclose(a.grad(), b.grad(), 1e-4, 1e-5));
    EXPECT_TRUE(torch::allclose(wa, up->weight.grad(), 1e-4, 1e-4));
    EXPECT_TRUE(torch::allclose(ba, up->bias.grad(), 1e-4, 1e-4));
  }
}

TEST(FastPaths, ScalarSchedulerStepMatchesTheTensorFormulas) {
  torch::manual_seed(3);
  for (PredictionType p : {PredictionType::kVelocity, PredictionType::kEpsilon, PredictionType::kSample}) {
    SchedulerConfig c;
    c.prediction = p;
    c.sampler = SamplerType::kDdim;  // deterministic
    c.clip_sample = false;
    nn::NoiseScheduler sched(c);
    const torch::Tensor x_t = torch::randn({4, 8, 2}), out = torch::randn({4, 8, 2});
    torch::Generator g = make_generator(0);
    for (int64_t t : {15, 9, 3, 0}) {
      const torch::Tensor tt = torch::full({4}, t, torch::kInt64);
      const torch::Tensor x0 = sched.predicted_x0(out, x_t, tt), eps = sched.predicted_eps(out, x_t, tt);
      const double ab_prev = t > 0 ? sched.alphas_cumprod()[t - 1].item<double>() : 1.0;
      const torch::Tensor expected = std::sqrt(ab_prev) * x0 + std::sqrt(1 - ab_prev) * eps;
      EXPECT_TRUE(torch::allclose(sched.step(out, t, x_t, g), expected, 1e-3, 1e-4)) << to_string(p) << " t " << t;
    }
  }
}

// With 2 threads the members train side by side, one thread each, in child processes (the default)
// or in threads: the same weights and losses as one after another with 1 thread, and so a member's
// chunks are the same.
TEST(FastPaths, EnsembleMembersTrainedSideBySideMatchOneThread) {
  const int threads = num_threads();
  PolicyConfig c = small_config("tiny");
  const std::vector<Episode> episodes = bimodal_episodes(6, 20, c.obs_dim, c.action_dim, 3);
  TrainConfig t;
  t.steps = 40;
  t.batch_size = 16;
  std::vector<std::vector<TrainStats>> stats;
  auto trained = [&](int n_threads, bool processes) {
    set_num_threads(n_threads);
    auto e = std::make_unique<PolicyEnsemble>(c, 3, 4);
    e->set_train_in_processes(processes);
    int last_done = 0, last_total = 0;
    stats.push_back(e->train(episodes, t, [&](int done, int total, double) {
      EXPECT_GE(done, last_done) << "progress went back";
      last_done = done, last_total = total;
    }));
    EXPECT_EQ(last_done, 3 * 40);
    EXPECT_EQ(last_total, 3 * 40);
    return e;
  };
  const auto serial = trained(1, true);
  const auto in_threads = trained(2, false);
  const auto in_processes = trained(2, true);
  set_num_threads(threads);
  const Vec o = Vec::Constant(c.obs_dim, 0.2f);
  for (int m = 0; m < 3; ++m) {
    const Mat reference = serial->member(m).sample(o, 11);
    EXPECT_TRUE(reference.isApprox(in_threads->member(m).sample(o, 11), 1e-5f)) << "member " << m;
    EXPECT_TRUE(reference.isApprox(in_processes->member(m).sample(o, 11), 1e-5f)) << "member " << m;
    for (size_t k = 1; k < stats.size(); ++k) {
      ASSERT_EQ(stats[k][m].losses.size(), 40u);
      for (size_t i = 0; i < 40; ++i) EXPECT_NEAR(stats[0][m].losses[i], stats[k][m].losses[i], 1e-5) << m << " " << i;
      EXPECT_GT(stats[k][m].seconds, 0);
    }
  }
}

TEST(FastPaths, EnsembleMembersSampledSideBySideGiveTheSameChunks) {
  const PolicyConfig c = small_config("cpu");
  PolicyEnsemble ensemble(c, 3, 4);
  Mat obs = Mat::Random(6, 5);
  ensemble.set_parallel_members(false);
  const std::vector<float> one_by_one = ensemble.action_variance(obs, 9);
  const PolicyEnsemble::Decision a = ensemble.decide(obs.row(0).transpose(), 5);
  ensemble.set_parallel_members(true);
  const std::vector<float> side_by_side = ensemble.action_variance(obs, 9);
  const PolicyEnsemble::Decision b = ensemble.decide(obs.row(0).transpose(), 5);
  ASSERT_EQ(one_by_one.size(), side_by_side.size());
  for (size_t i = 0; i < one_by_one.size(); ++i) EXPECT_NEAR(one_by_one[i], side_by_side[i], 1e-5 * (1 + one_by_one[i])) << i;
  EXPECT_TRUE(a.chunk.isApprox(b.chunk, 1e-5f));
  EXPECT_NEAR(a.variance, b.variance, 1e-5 * (1 + a.variance));
  EXPECT_GT(a.variance, 0) << "members initialised alike";
}

TEST(FastPaths, FusedOptimizerTrainsLikeTorchsAdamW) {
  const PolicyConfig c = small_config("tiny");
  const ChunkDataset data = ChunkDataset::from_episodes(bimodal_episodes(10, 20, 5, 3, 2), 16);
  TrainConfig t;
  t.steps = 40;
  t.batch_size = 32;
  t.warmup_steps = 5;
  t.grad_clip = 0.05;  // small enough to clip most steps
  std::vector<std::vector<float>> losses;
  std::vector<Mat> samples;
  for (bool fused : {false, true}) {
    set_fused_optimizer(fused);
    DiffusionPolicy policy(c, 3, false);
    losses.push_back(train(policy, data, t).losses);
    samples.push_back(policy.sample(data.obs.row(0).transpose(), 9));
  }
  set_fused_optimizer(true);
  for (size_t i = 0; i < losses[0].size(); ++i) EXPECT_NEAR(losses[1][i], losses[0][i], 1e-4 * (1 + losses[0][i])) << "step " << i;
  EXPECT_TRUE(samples[1].isApprox(samples[0], 1e-3f)) << "the EMA weights differ";
}

// With 2 threads a training step splits its minibatch with a forked child, one thread each: the same
// losses and weights as one process, up to float rounding; and when the child dies, training goes
// on in this process alone, still the same.
// A killed child is dead, its socket closed, once /proc says it is a zombie (not yet reaped).
static bool wait_until_dead(pid_t pid) {
  for (int i = 0; i < 500; ++i) {
    std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
    std::string pid_field, comm, state;
    if (!(stat >> pid_field >> comm >> state) || state == "Z" || state == "X") return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return false;
}

TEST(FastPaths, DataParallelTrainingMatchesOneProcess) {
  const int threads = num_threads();
  set_num_threads(2);
  const PolicyConfig c = small_config("tiny");
  const ChunkDataset data = ChunkDataset::from_episodes(bimodal_episodes(10, 20, 5, 3, 2), 16);
  TrainConfig t;
  t.steps = 30;
  t.batch_size = 33;  // odd: halves of 16 and 17 rows
  t.warmup_steps = 5;
  std::vector<std::vector<float>> losses;
  std::vector<Mat> samples;
  // one process; two; two with the child killed at step 10 (it dies while the step asks it or waits
  // for it); and killed and gone before step 10 asks it (the ask itself fails)
  for (const int variant : {0, 1, 2, 3}) {
    set_data_parallel(variant > 0);
    DiffusionPolicy policy(c, 3, false);
    {
      Trainer trainer(policy, data, t);
      if (variant == 0) EXPECT_EQ(trainer.worker_pid(), -1);
      else ASSERT_GT(trainer.worker_pid(), 0) << "no child process at 2 threads";
      losses.emplace_back();
      for (int i = 0; i < t.steps; ++i) {
        if (variant >= 2 && i == 10) {
          const pid_t child = trainer.worker_pid();
          ::kill(child, SIGKILL);
          if (variant == 3) ASSERT_TRUE(wait_until_dead(child)) << "the killed child did not die";
          losses.back().push_back(trainer.step());
          EXPECT_EQ(trainer.worker_pid(), -1) << "the dead child is still counted on";
          continue;
        }
        losses.back().push_back(trainer.step());
      }
    }
    samples.push_back(policy.sample(data.obs.row(0).transpose(), 9));
  }
  set_data_parallel(true);
  set_num_threads(threads);
  for (size_t v = 1; v < losses.size(); ++v) {
    for (size_t i = 0; i < losses[0].size(); ++i)
      EXPECT_NEAR(losses[v][i], losses[0][i], 1e-4 * (1 + losses[0][i])) << "variant " << v << " step " << i;
    EXPECT_TRUE(samples[v].isApprox(samples[0], 1e-3f)) << "variant " << v << ": the EMA weights differ";
  }
  EXPECT_GT(losses[0].front(), losses[0].back()) << "the loss did not fall";
}

// A minibatch too small to split, or one thread, trains in this process.
TEST(FastPaths, SmallMinibatchesAndOneThreadTrainAlone) {
  const int threads = num_threads();
  const PolicyConfig c = small_config("tiny");
  const ChunkDataset data = ChunkDataset::from_episodes(bimodal_episodes(4, 20, 5, 3, 2), 16);
  TrainConfig t;
  t.steps = 2;
  t.batch_size = 8;
  set_num_threads(2);
  DiffusionPolicy policy(c, 3, false);
  EXPECT_EQ(Trainer(policy, data, t).worker_pid(), -1);
  t.batch_size = 32;
  set_num_threads(1);
  EXPECT_EQ(Trainer(policy, data, t).worker_pid(), -1);
  set_num_threads(threads);
}

// With 2 threads a data set's pairs are scored in two one-thread child processes, alternate blocks
// each: the same expected losses and the same screened threshold as one process.
TEST(FastPaths, ScoringSplitBetweenTwoProcessesMatchesOneProcess) {
  const int threads = num_threads();
  set_num_threads(2);
  const PolicyConfig c = small_config("tiny");
  const ChunkDataset data = ChunkDataset::from_episodes(bimodal_episodes(10, 20, 5, 3, 2), 16);
  ASSERT_GE(data.size(), 4 * 32) << "too few pairs for the screening pass to split";
  DiffusionPolicy policy(c, 3, false);
  TrainConfig t;
  t.steps = 20;
  t.batch_size = 32;
  train(policy, data, t);
  const ChunkDataset some = data.subset(40, 1);  // 10 blocks of 4 pairs at 512 rows
  std::vector<std::vector<float>> losses;
  std::vector<LossQuantile> thresholds;
  std::vector<int> children;
  for (const bool split : {false, true}) {
    set_data_parallel(split);
    const int before = children_started();
    int last_done = 0;
    losses.push_back(policy.expected_losses(some, 7, 512, [&](int done, int total, double) {
      EXPECT_GE(done, last_done) << "progress went back";
      EXPECT_LE(done, total);
      last_done = done;
    }));
    EXPECT_EQ(last_done, some.size());
    thresholds.push_back(policy.loss_quantile(data, 0.9, 7, 512, true));
    children.push_back(children_started() - before);
  }
  set_data_parallel(true);
  set_num_threads(threads);
  EXPECT_EQ(children[0], 0);
  EXPECT_GE(children[1], 4) << "two children for the losses, two for the screening pass (and two a refining round)";
  ASSERT_EQ(losses[0].size(), losses[1].size());
  for (size_t i = 0; i < losses[0].size(); ++i) EXPECT_NEAR(losses[1][i], losses[0][i], 1e-4 * (1 + losses[0][i])) << "pair " << i;
  EXPECT_NEAR(thresholds[1].threshold, thresholds[0].threshold, 1e-4 * (1 + thresholds[0].threshold));
  EXPECT_EQ(thresholds[1].refined, thresholds[0].refined);
  EXPECT_GT(thresholds[0].screen_samples, 0) << "the screening pass did not run";
}

}  // namespace dd
