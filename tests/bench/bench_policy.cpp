// Speed of the diffusion policy's hot paths, for the paper's reference size (down_dims 64,128,256,
// observation dim 20, action dim 10, T_p 16, T_d 16) and for the CPU default (down_dims 32,64,128):
//   TrainStep     one gradient step at batch 256 (TrainStepTorchMish: with torch's Mish kernels;
//                 TrainStepTorchAdamW: with torch's AdamW per tensor instead of the fused optimiser)
//   Sample        one 16-step DDPM sampling at batch 1 (denoising passes on nn::FastDenoiser)
//   ...Torch      the same on torch's operators (the path before FastDenoiser, for the ratio)
//   ExpectedLoss  one expected loss at N_b = 512
//   Decision      sampling plus expected loss: what every control decision costs
//   DiffDecision  Diff-DAgger's decision (Method::decide) with compared rules (method.compare_scores):
//                 none; epsilon and target@4 (results/score_space/push_2experts_compare.yaml: epsilon
//                 is scored from the decision's own rows); epsilon@8 and target@4 (two rules with rows
//                 of their own: what that config cost before the rows were shared)
//   ...Bf16       the same with bfloat16 products (InferencePrecision::kBFloat16, an option)
//   EnsembleDecision  5 members sample a chunk each, side by side (...Serial: one after another)
//   EnsembleConv  5 members' convolution forward and backward: separate, or grouped (groups = 5)
//   EnsembleSpread  the ensemble's threshold setting: 5 members sample for 256 observations (T_p 32);
//                 ...Torch: on torch's operators; ...Serial: members one after another
//   EnsembleTrain  one ensemble update (5 members x 20 steps, batch 128, T_p 32), members side by side
//                 in child processes (the default); ...Threads: in threads; ...Serial: one after another
//                 with both threads inside each
//   TrainerStart  a Trainer made, one step, destroyed: the fork's cost per training run (...OneProcess: none)
//   Threshold     the alpha-quantile of 400 pairs' expected losses, screened; ...AllRows: unscreened
//   Sgemm         a large square sgemm through the same OpenBLAS: this machine's practical fp32
//                 peak, the yardstick for the others (counter GFLOPS)
// libtorch runs with 2 intra-op threads (or $DD_THREADS).
#include <benchmark/benchmark.h>
#include <spdlog/spdlog.h>

#include <memory>
#include <string>
#include <vector>

#include "core/chunks.h"
#include "core/ensemble.h"
#include "core/method.h"
#include "core/nn/bf16_gemm.h"
#include "core/nn/mish.h"
#include "core/nn/policy_impl.h"
#include "core/policy.h"
#include "core/runtime.h"
#include "core/synthetic.h"
#include "core/trainer.h"

namespace dd {
namespace {

PolicyConfig bench_config(std::vector<int> down_dims, int step_embed) {
  PolicyConfig c;
  c.obs_dim = 20;
  c.action_dim = 10;
  c.horizon = 16;
  c.action_steps = 8;
  c.unet.down_dims = std::move(down_dims);
  c.unet.step_embed_dim = step_embed;
  c.scheduler.num_train_timesteps = 16;
  c.scheduler.num_inference_steps = 16;
  return c;
}

const ChunkDataset& bench_data() {
  static const ChunkDataset d = ChunkDataset::from_episodes(bimodal_episodes(40, 50, 20, 10, 1), 16);
  return d;
}

void TrainStep(benchmark::State& state, const PolicyConfig& config, bool torch_mish, bool torch_adamw = false,
               bool data_parallel = true) {
  nn::set_fused_mish(!torch_mish);
  set_fused_optimizer(!torch_adamw);
  set_data_parallel(data_parallel);
  DiffusionPolicy policy(config, 0);
  TrainConfig t;
  t.batch_size = 256;
  t.steps = 1000000;
  Trainer trainer(policy, bench_data(), t);
  trainer.step();  // warm-up: allocation and oneDNN setup
  for (auto _ : state) benchmark::DoNotOptimize(trainer.step());
  nn::set_fused_mish(true);
  set_fused_optimizer(true);
  set_data_parallel(true);
}

// What a training run pays once for the two-process split: a Trainer made, its first step taken
// (oneDNN's setup in both processes) and the trainer destroyed, with the child forked and killed
// (two processes) or not (one). The difference is the fork's cost per DAgger update.
void TrainerStart(benchmark::State& state, const PolicyConfig& config, bool data_parallel) {
  set_data_parallel(data_parallel);
  DiffusionPolicy policy(config, 0);
  TrainConfig t;
  t.batch_size = 256;
  t.steps = 1000000;
  for (auto _ : state) {
    Trainer trainer(policy, bench_data(), t);
    benchmark::DoNotOptimize(trainer.step());
  }
  set_data_parallel(true);
}

// The bfloat16 variants are skipped where oneDNN has no bf16 matmul (a CPU without AVX-512).
bool unavailable(benchmark::State& state, InferencePrecision precision) {
  if (precision != InferencePrecision::kBFloat16 || nn::have_bf16_gemm()) return false;
  state.SkipWithError("no oneDNN bf16 matmul on this CPU (it needs AVX-512)");
  return true;
}

void Sample(benchmark::State& state, const PolicyConfig& config, bool torch_denoise,
            InferencePrecision precision = InferencePrecision::kFloat32) {
  if (unavailable(state, precision)) return;
  DiffusionPolicy policy(config, 0);
  policy.impl().torch_denoise = torch_denoise;
  policy.set_inference_precision(precision);
  const Vec obs = bench_data().obs.row(0).transpose();
  uint64_t seed = 0;
  policy.sample(obs, seed++);
  for (auto _ : state) benchmark::DoNotOptimize(policy.sample(obs, seed++));
}

void ExpectedLoss(benchmark::State& state, const PolicyConfig& config, InferencePrecision precision = InferencePrecision::kFloat32) {
  if (unavailable(state, precision)) return;
  DiffusionPolicy policy(config, 0);
  policy.set_inference_precision(precision);
  const Vec obs = bench_data().obs.row(0).transpose();
  const Mat chunk = bench_data().chunk(0);
  uint64_t seed = 0;
  policy.expected_loss(obs, chunk, seed++);
  for (auto _ : state) benchmark::DoNotOptimize(policy.expected_loss(obs, chunk, seed++, kDefaultLossSamples));
}

void Decision(benchmark::State& state, const PolicyConfig& config, bool torch_denoise,
              InferencePrecision precision = InferencePrecision::kFloat32) {
  if (unavailable(state, precision)) return;
  DiffusionPolicy policy(config, 0);
  policy.impl().torch_denoise = torch_denoise;
  policy.set_inference_precision(precision);
  const Vec obs = bench_data().obs.row(0).transpose();
  uint64_t seed = 0;
  policy.decide(obs, seed++);
  for (auto _ : state) benchmark::DoNotOptimize(policy.decide(obs, seed++, kDefaultLossSamples));
}

void DiffDecision(benchmark::State& state, const PolicyConfig& config, std::vector<std::string> compare) {
  MethodConfig mc;
  mc.compare_scores = std::move(compare);
  const std::unique_ptr<Method> method = make_method("diff", config, mc, 0);
  const Vec obs = bench_data().obs.row(0).transpose();
  uint64_t seed = 0;
  method->decide(obs, seed++);
  for (auto _ : state) benchmark::DoNotOptimize(method->decide(obs, seed++));
}

// One Ensemble-DAgger decision: 5 members each sample a chunk (side by side, or one after another).
void EnsembleDecision(benchmark::State& state, const PolicyConfig& config, bool parallel) {
  PolicyEnsemble ensemble(config, 5, 0);
  ensemble.set_parallel_members(parallel);
  const Vec obs = bench_data().obs.row(0).transpose();
  uint64_t seed = 0;
  ensemble.decide(obs, seed++);
  for (auto _ : state) benchmark::DoNotOptimize(ensemble.decide(obs, seed++));
}

// One member's chunks for many training observations (the bench's rows repeated), as an ensemble's
// threshold samples them: sample_batch's blocks, or every row in one denoising loop as before the
// blocks. Counter `rows_per_s`.
void SampleManyRows(benchmark::State& state, PolicyConfig config, bool one_batch) {
  config.horizon = 32;
  DiffusionPolicy policy(config, 0);
  const Mat& base = bench_data().obs;
  Mat obs(state.range(0), base.cols());
  for (Eigen::Index i = 0; i < obs.rows(); ++i) obs.row(i) = base.row(i % base.rows());
  uint64_t seed = 0;
  for (auto _ : state) {
    if (one_batch) {
      torch::Generator gen = make_generator(seed++);
      benchmark::DoNotOptimize(policy.impl().sample(policy.impl().obs_tensor(obs), gen));
    } else {
      benchmark::DoNotOptimize(policy.sample_batch(obs, seed++));
    }
  }
  state.counters["rows_per_s"] = benchmark::Counter(static_cast<double>(state.range(0)), benchmark::Counter::kIsIterationInvariantRate);
}

// One sampling of B rows at once (T_p 32), B = state.range(0): where FastDenoiser's lead at batch 1
// turns into a loss against torch's oneDNN convolutions.
void SampleRows(benchmark::State& state, PolicyConfig config, bool torch_denoise) {
  config.horizon = 32;
  DiffusionPolicy policy(config, 0);
  policy.impl().torch_denoise = torch_denoise;
  const Mat obs = bench_data().obs.topRows(state.range(0));
  uint64_t seed = 0;
  policy.sample_batch(obs, seed++);
  for (auto _ : state) benchmark::DoNotOptimize(policy.sample_batch(obs, seed++));
}

// The ensemble's threshold setting: 5 members each sample a chunk for 256 training observations
// (T_p 32, the arm presets' horizon). Denoising passes on FastDenoiser (the default) or on torch's
// operators, members side by side (one thread each) or one after another (all threads each).
void EnsembleSpread(benchmark::State& state, PolicyConfig config, bool torch_denoise, bool parallel) {
  config.horizon = 32;
  PolicyEnsemble ensemble(config, 5, 0);
  ensemble.set_parallel_members(parallel);
  for (int m = 0; m < ensemble.size(); ++m) ensemble.member(m).impl().torch_denoise = torch_denoise;
  const Mat obs = bench_data().obs.topRows(256);
  uint64_t seed = 0;
  for (auto _ : state) benchmark::DoNotOptimize(ensemble.action_variance(obs, seed++));
}

// One ensemble update: 5 members, 20 steps each at batch 128 (T_p 32), side by side (one thread
// each) or one after another (all threads in each step).
void EnsembleTrain(benchmark::State& state, PolicyConfig config, bool parallel, bool processes = true) {
  config.horizon = 32;
  PolicyEnsemble ensemble(config, 5, 0);
  ensemble.set_parallel_members(parallel);
  ensemble.set_train_in_processes(processes);
  const std::vector<Episode> episodes = bimodal_episodes(40, 50, 20, 10, 1);
  TrainConfig t;
  t.batch_size = 128;
  t.steps = 20;
  for (auto _ : state) benchmark::DoNotOptimize(ensemble.train(episodes, t));
}

// The threshold over 400 training pairs of a briefly trained policy, screened (1/8 of the rows
// first) or every pair at N_b = 512; counter `refined`: pairs scored at 512 rows.
void Threshold(benchmark::State& state, const PolicyConfig& config, bool screen, bool data_parallel = true) {
  DiffusionPolicy policy(config, 0);
  TrainConfig t;
  t.batch_size = 128;
  t.steps = 300;
  train(policy, bench_data(), t);
  const ChunkDataset pairs = bench_data().subset(400, 1);
  uint64_t seed = 0;
  LossQuantile q;
  set_data_parallel(data_parallel);
  for (auto _ : state) q = policy.loss_quantile(pairs, 0.99, seed++, kDefaultLossSamples, screen);
  set_data_parallel(true);
  state.counters["refined"] = q.refined;
}

// Would a batched ensemble train faster? One U-Net-sized convolution (64 -> 64 channels, kernel 5,
// T 32, batch 128), forward and backward, for 5 members: 5 separate convolutions, or one grouped
// convolution over the members' stacked channels (groups = 5).
void EnsembleConv(benchmark::State& state, bool grouped) {
  constexpr int M = 5, C = 64, K = 5, T = 32, B = 128;
  std::vector<torch::Tensor> w, x;
  for (int m = 0; m < M; ++m) {
    w.push_back(torch::randn({C, C, K}).requires_grad_(true));
    x.push_back(torch::randn({B, C, T}));
  }
  const torch::Tensor wg = torch::cat(w, 0).detach().requires_grad_(true);
  const torch::Tensor xg = torch::cat(x, 1);
  for (auto _ : state) {
    if (grouped) {
      torch::conv1d(xg, wg, {}, 1, K / 2, 1, M).sum().backward();
    } else {
      for (int m = 0; m < M; ++m) torch::conv1d(x[m], w[m], {}, 1, K / 2).sum().backward();
    }
  }
}

// What the machine's BLAS reaches on a large product, as GFLOPS.
void Sgemm(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const torch::Tensor a = torch::rand({n, n}), b = torch::rand({n, n});
  torch::Tensor c = torch::mm(a, b);
  for (auto _ : state) {
    torch::mm_out(c, a, b);
    benchmark::DoNotOptimize(c.data_ptr<float>());
  }
  state.counters["GFLOPS"] = benchmark::Counter(2.0 * n * n * n, benchmark::Counter::kIsIterationInvariantRate, benchmark::Counter::kIs1000);
}
BENCHMARK(Sgemm)->Arg(2048)->Unit(benchmark::kMillisecond)->UseRealTime();

const PolicyConfig kReference = bench_config({64, 128, 256}, 128);
const PolicyConfig kCpuDefault = bench_config(UnetConfig{}.down_dims, UnetConfig{}.step_embed_dim);

// At two threads or more a step splits its minibatch with a forked child (core/trainer.cpp): wall-clock
// time, since the child's CPU time is not this process's.
BENCHMARK_CAPTURE(TrainStep, 64_128_256, kReference, false)->Name("BM_TrainStep_64_128_256")->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(TrainStep, 64_128_256, kReference, false, false, false)->Name("BM_TrainStepOneProcess_64_128_256")->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(TrainStep, 64_128_256, kReference, true)->Name("BM_TrainStepTorchMish_64_128_256")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(TrainStep, 64_128_256, kReference, false, true)->Name("BM_TrainStepTorchAdamW_64_128_256")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(Sample, 64_128_256, kReference, false)->Name("BM_Sample_64_128_256")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(Sample, 64_128_256, kReference, true)->Name("BM_SampleTorch_64_128_256")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(ExpectedLoss, 64_128_256, kReference)->Name("BM_ExpectedLoss_64_128_256")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(Decision, 64_128_256, kReference, false)->Name("BM_Decision_64_128_256")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(Decision, 64_128_256, kReference, true)->Name("BM_DecisionTorch_64_128_256")->Unit(benchmark::kMillisecond);
constexpr auto kBf16 = InferencePrecision::kBFloat16;
BENCHMARK_CAPTURE(Sample, 64_128_256, kReference, false, kBf16)->Name("BM_SampleBf16_64_128_256")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(ExpectedLoss, 64_128_256, kReference, kBf16)->Name("BM_ExpectedLossBf16_64_128_256")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(Decision, 64_128_256, kReference, false, kBf16)->Name("BM_DecisionBf16_64_128_256")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(Sample, 32_64_128, kCpuDefault, false, kBf16)->Name("BM_SampleBf16_32_64_128")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(ExpectedLoss, 32_64_128, kCpuDefault, kBf16)->Name("BM_ExpectedLossBf16_32_64_128")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(Decision, 32_64_128, kCpuDefault, false, kBf16)->Name("BM_DecisionBf16_32_64_128")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(TrainStep, 32_64_128, kCpuDefault, false)->Name("BM_TrainStep_32_64_128")->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(TrainStep, 32_64_128, kCpuDefault, false, false, false)->Name("BM_TrainStepOneProcess_32_64_128")->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(TrainerStart, 32_64_128, kCpuDefault, true)->Name("BM_TrainerStart_32_64_128")->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(TrainerStart, 32_64_128, kCpuDefault, false)->Name("BM_TrainerStartOneProcess_32_64_128")->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(TrainStep, 32_64_128, kCpuDefault, true)->Name("BM_TrainStepTorchMish_32_64_128")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(TrainStep, 32_64_128, kCpuDefault, false, true)->Name("BM_TrainStepTorchAdamW_32_64_128")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(Sample, 32_64_128, kCpuDefault, false)->Name("BM_Sample_32_64_128")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(Sample, 32_64_128, kCpuDefault, true)->Name("BM_SampleTorch_32_64_128")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(ExpectedLoss, 32_64_128, kCpuDefault)->Name("BM_ExpectedLoss_32_64_128")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(Decision, 32_64_128, kCpuDefault, false)->Name("BM_Decision_32_64_128")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(Decision, 32_64_128, kCpuDefault, true)->Name("BM_DecisionTorch_32_64_128")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(DiffDecision, 32_64_128, kCpuDefault, {})->Name("BM_DiffDecision_32_64_128")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(DiffDecision, 32_64_128, kCpuDefault, {"epsilon", "target@4"})->Name("BM_DiffDecisionCompareShared_32_64_128")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(DiffDecision, 32_64_128, kCpuDefault, {"epsilon@8", "target@4"})->Name("BM_DiffDecisionCompareOwnRows_32_64_128")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(EnsembleDecision, 32_64_128, kCpuDefault, true)->Name("BM_EnsembleDecision_32_64_128")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(EnsembleDecision, 32_64_128, kCpuDefault, false)->Name("BM_EnsembleDecisionSerial_32_64_128")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(EnsembleDecision, 64_128_256, kReference, true)->Name("BM_EnsembleDecision_64_128_256")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(EnsembleDecision, 64_128_256, kReference, false)->Name("BM_EnsembleDecisionSerial_64_128_256")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(EnsembleConv, separate, false)->Name("BM_EnsembleConvSeparate")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(EnsembleConv, grouped, true)->Name("BM_EnsembleConvGrouped")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(SampleRows, 32_64_128, kCpuDefault, false)->Name("BM_SampleRows_32_64_128")->RangeMultiplier(4)->Range(1, 256)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(SampleRows, 32_64_128, kCpuDefault, true)->Name("BM_SampleRowsTorch_32_64_128")->RangeMultiplier(4)->Range(1, 256)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(EnsembleSpread, 32_64_128, kCpuDefault, false, true)->Name("BM_EnsembleSpread_32_64_128")->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime()->UseRealTime();
BENCHMARK_CAPTURE(EnsembleSpread, 32_64_128, kCpuDefault, true, true)->Name("BM_EnsembleSpreadTorch_32_64_128")->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime()->UseRealTime();
BENCHMARK_CAPTURE(EnsembleSpread, 32_64_128, kCpuDefault, false, false)->Name("BM_EnsembleSpreadSerial_32_64_128")->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime()->UseRealTime();
BENCHMARK_CAPTURE(EnsembleSpread, 32_64_128, kCpuDefault, true, false)->Name("BM_EnsembleSpreadTorchSerial_32_64_128")->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime()->UseRealTime();
BENCHMARK_CAPTURE(SampleManyRows, blocks, kCpuDefault, false)->Name("BM_SampleManyRows_32_64_128")->Arg(512)->Arg(16384)->Unit(benchmark::kMillisecond)->Iterations(1)->UseRealTime();
BENCHMARK_CAPTURE(SampleManyRows, one_batch, kCpuDefault, true)->Name("BM_SampleManyRowsOneBatch_32_64_128")->Arg(512)->Arg(16384)->Unit(benchmark::kMillisecond)->Iterations(1)->UseRealTime();
BENCHMARK_CAPTURE(EnsembleTrain, 32_64_128, kCpuDefault, true)->Name("BM_EnsembleTrain_32_64_128")->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime()->UseRealTime();
BENCHMARK_CAPTURE(EnsembleTrain, 32_64_128, kCpuDefault, true, false)->Name("BM_EnsembleTrainThreads_32_64_128")->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime()->UseRealTime();
BENCHMARK_CAPTURE(EnsembleTrain, 32_64_128, kCpuDefault, false)->Name("BM_EnsembleTrainSerial_32_64_128")->Unit(benchmark::kMillisecond)->MeasureProcessCPUTime()->UseRealTime();
// At two threads or more the pairs are scored in two child processes: wall-clock time.
BENCHMARK_CAPTURE(Threshold, 32_64_128, kCpuDefault, true)->Name("BM_Threshold_32_64_128")->Unit(benchmark::kMillisecond)->Iterations(2)->UseRealTime();
BENCHMARK_CAPTURE(Threshold, 32_64_128, kCpuDefault, true, false)->Name("BM_ThresholdOneProcess_32_64_128")->Unit(benchmark::kMillisecond)->Iterations(2)->UseRealTime();
BENCHMARK_CAPTURE(Threshold, 32_64_128, kCpuDefault, false)->Name("BM_ThresholdAllRows_32_64_128")->Unit(benchmark::kMillisecond)->Iterations(2)->UseRealTime();
BENCHMARK_CAPTURE(Threshold, 32_64_128, kCpuDefault, false, false)->Name("BM_ThresholdAllRowsOneProcess_32_64_128")->Unit(benchmark::kMillisecond)->Iterations(2)->UseRealTime();

}  // namespace
}  // namespace dd

int main(int argc, char** argv) {
  spdlog::set_level(spdlog::level::warn);
  const int threads = dd::set_num_threads();
  benchmark::AddCustomContext("torch_threads", std::to_string(threads));
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
