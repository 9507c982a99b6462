// What bfloat16 inference costs in agreement with float32: a trained policy's expected losses over
// a data set's training pairs, once in each precision from the same noise draws, and then
//   - Spearman's rank correlation of the two sets of losses,
//   - the alpha-quantile threshold each precision sets, and
//   - query agreement: the share of pairs both precisions put on the same side of their own threshold,
//     and of the pairs float32 flags, the share bfloat16 flags too,
// with the seconds each took. The gate's decisions depend on the ranks, so this is the measure the
// option is judged by.
//   build/tests/bench/precision_agreement CHECKPOINT DATASET [pairs=2000] [n_samples=512] [alpha=0.99]
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "core/chunks.h"
#include "core/dataset.h"
#include "core/gate.h"
#include "core/nn/bf16_gemm.h"
#include "core/policy.h"
#include "core/runtime.h"

int main(int argc, char** argv) {
  using namespace dd;
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s CHECKPOINT DATASET [pairs=2000] [n_samples=512] [alpha=0.99]\n", argv[0]);
    return 2;
  }
  if (!nn::have_bf16_gemm()) {
    std::fprintf(stderr, "%s: no oneDNN bf16 matmul here (built without libdnnl-dev, or a CPU without AVX-512)\n", argv[0]);
    return 1;
  }
  set_num_threads();
  const auto policy = DiffusionPolicy::from_checkpoint(argv[1]);
  const int max_pairs = argc > 3 ? std::stoi(argv[3]) : 2000;
  const int n_samples = argc > 4 ? std::stoi(argv[4]) : kDefaultLossSamples;
  const double alpha = argc > 5 ? std::stod(argv[5]) : 0.99;
  std::vector<Episode> episodes;
  for (const RecordedEpisode& e : read_dataset(argv[2]))
    if (e.success) episodes.push_back(e.expert_steps());
  const ChunkDataset data = ChunkDataset::from_episodes(episodes, policy->config().horizon).subset(max_pairs, 1);
  auto losses = [&](InferencePrecision p, double& seconds) {
    policy->set_inference_precision(p);
    const auto t = std::chrono::steady_clock::now();
    std::vector<float> l = policy->expected_losses(data, 11, n_samples);
    seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
    return l;
  };
  double s32 = 0, s16 = 0;
  const std::vector<float> f32 = losses(InferencePrecision::kFloat32, s32), bf16 = losses(InferencePrecision::kBFloat16, s16);
  const float t32 = quantile(f32, alpha), t16 = quantile(bf16, alpha);
  int same = 0, flagged = 0, both = 0;
  for (size_t i = 0; i < f32.size(); ++i) {
    const bool a = f32[i] > t32, b = bf16[i] > t16;
    same += a == b;
    flagged += a;
    both += a && b;
  }
  std::printf("%s on %s: %d pairs, N_b %d, alpha %.3f\n", argv[1], argv[2], data.size(), n_samples, alpha);
  std::printf("| | float32 | bfloat16 |\n|---|---|---|\n");
  std::printf("| seconds | %.1f | %.1f |\n| threshold | %.5f | %.5f |\n", s32, s16, t32, t16);
  std::printf("Spearman rank correlation %.4f; same side of the threshold %.2f%% of pairs; of the %d pairs float32 flags, "
              "bfloat16 flags %d\n",
              spearman(f32, bf16), 100.0 * same / static_cast<double>(f32.size()), flagged, both);
  return 0;
}
