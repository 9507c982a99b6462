// How precisely a trained policy reproduces its demonstrations where precision matters: samples one
// chunk per demonstration step and prints the error of its first commanded TCP position against the
// expert's, in millimetres, by how far the held object is from its target then. For the arm tasks
// whose actions are absolute TCP targets (stacking, plugging).
//   build/tests/bench/action_error CHECKPOINT TASK [demos=20] [expert=planner]
#include <cstdio>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/chunks.h"
#include "core/evaluation.h"
#include "core/policy.h"
#include "core/runtime.h"
#include "envs/registry.h"

int main(int argc, char** argv) {
  using namespace dd;
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s CHECKPOINT TASK [demos=20] [expert=planner]\n", argv[0]);
    return 2;
  }
  set_num_threads();
  const auto policy = DiffusionPolicy::from_checkpoint(argv[1]);
  const std::string task = argv[2];
  const int demos = argc > 3 ? std::stoi(argv[3]) : 20;
  const std::string mode = argc > 4 ? argv[4] : "planner";
  // the last three observation values are "target minus object" on both tasks
  const int obs_dim = policy->config().obs_dim;
  auto env = make_env(task);
  auto expert = make_expert(task, mode);
  Mat obs(0, obs_dim), expert_xyz(0, 3);
  int kept = 0;
  for (uint64_t seed = 1; kept < demos && seed < 1000; ++seed) {
    const RecordedEpisode e = expert_episode(*env, *expert, seed);
    if (!e.success) continue;
    ++kept;
    const Eigen::Index n = e.steps(), at = obs.rows();
    obs.conservativeResize(at + n, obs_dim);
    expert_xyz.conservativeResize(at + n, 3);
    obs.bottomRows(n) = e.obs;
    expert_xyz.bottomRows(n) = e.actions.leftCols(3);
  }
  const std::vector<Mat> chunks = policy->sample_batch(obs, 7);
  struct Bin {
    const char* name;
    double lo, hi;
    std::vector<double> xy;
  };
  std::vector<Bin> bins{{"< 5 mm", 0, 0.005, {}}, {"5 mm - 2 cm", 0.005, 0.02, {}}, {"2 - 10 cm", 0.02, 0.10, {}}, {"> 10 cm", 0.10, 1e9, {}}};
  for (Eigen::Index i = 0; i < obs.rows(); ++i) {
    const double d = obs.row(i).tail(3).head(2).norm();
    const double err = (chunks[static_cast<size_t>(i)].row(0).head(2) - expert_xyz.row(i).head(2)).norm();
    for (Bin& b : bins)
      if (d >= b.lo && d < b.hi) b.xy.push_back(err * 1000);
  }
  std::printf("%s on %s, %d demonstrations (%ld steps): first commanded TCP xy against the expert's [mm]\n", argv[1], task.c_str(), kept,
              static_cast<long>(obs.rows()));
  std::printf("%-14s %7s %8s %8s %8s\n", "object-target", "steps", "median", "p90", "mean");
  for (Bin& b : bins) {
    if (b.xy.empty()) continue;
    std::sort(b.xy.begin(), b.xy.end());
    double mean = 0;
    for (double v : b.xy) mean += v;
    mean /= b.xy.size();
    std::printf("%-14s %7zu %8.2f %8.2f %8.2f\n", b.name, b.xy.size(), b.xy[b.xy.size() / 2], b.xy[b.xy.size() * 9 / 10], mean);
  }
  return 0;
}
