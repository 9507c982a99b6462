// What screening Diff-DAgger's gate (DiffusionPolicy::decide_screened) saves on a trained policy, and
// whether it keeps the verdicts: decisions at observations of a run's data set (every recorded step,
// the robot's as well as the expert's), each made twice from the same seed, with all N_b rows and
// screened against THRESHOLD (the run's, from its queries.jsonl), interleaved. Prints the seconds of
// each, how many rows the screened decisions stopped at, and how often the two verdicts differ.
//   build/tests/bench/gate_screen CHECKPOINT DATASET THRESHOLD [decisions=300] [n_samples=512]
#include <chrono>
#include <cstdio>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "core/dataset.h"
#include "core/policy.h"
#include "core/runtime.h"

int main(int argc, char** argv) {
  using namespace dd;
  if (argc < 4) {
    std::fprintf(stderr, "usage: %s CHECKPOINT DATASET THRESHOLD [decisions=300] [n_samples=512]\n", argv[0]);
    return 2;
  }
  set_num_threads();
  const auto policy = DiffusionPolicy::from_checkpoint(argv[1]);
  const float threshold = std::stof(argv[3]);
  const int decisions = argc > 4 ? std::stoi(argv[4]) : 300;
  const int n_samples = argc > 5 ? std::stoi(argv[5]) : kDefaultLossSamples;
  std::vector<Vec> observations;
  for (const RecordedEpisode& e : read_dataset(argv[2]))
    for (Eigen::Index t = 0; t < e.obs.rows(); ++t) observations.push_back(e.obs.row(t).transpose());
  if (observations.empty()) {
    std::fprintf(stderr, "%s: no recorded steps\n", argv[2]);
    return 1;
  }
  std::mt19937_64 pick(5);
  std::map<int, int> rows;
  int differ = 0, violations = 0;
  double plain_s = 0, screened_s = 0;
  using Clock = std::chrono::steady_clock;
  for (int i = 0; i < decisions; ++i) {
    const Vec& obs = observations[pick() % observations.size()];
    const uint64_t seed = 1000 + static_cast<uint64_t>(i);
    auto t = Clock::now();
    const Decision full = policy->decide(obs, seed, n_samples);
    plain_s += std::chrono::duration<double>(Clock::now() - t).count();
    t = Clock::now();
    const Decision screened = policy->decide_screened(obs, seed, n_samples, threshold);
    screened_s += std::chrono::duration<double>(Clock::now() - t).count();
    ++rows[screened.rows];
    violations += full.loss > threshold;
    differ += (full.loss > threshold) != (screened.loss > threshold);
  }
  std::printf("%s at %d observations of %s, threshold %.5f, N_b %d, %d threads\n", argv[1], decisions, argv[2], threshold, n_samples,
              num_threads());
  std::printf("| | all rows | screened |\n|---|---|---|\n| ms a decision | %.1f | %.1f |\n", 1e3 * plain_s / decisions,
              1e3 * screened_s / decisions);
  std::printf("screened decisions by the rows they stopped at:");
  for (const auto& [r, n] : rows) std::printf(" %d: %d", r, n);
  std::printf("\nviolations with all rows %d; verdicts that differ between the two draws %d\n", violations, differ);
  return 0;
}
