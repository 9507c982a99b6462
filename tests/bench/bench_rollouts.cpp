// Speed of RQ1/RQ2's rollouts on stacking with Diff-DAgger's decisions (a chunk sampled and its
// expected loss at N_b 512 every T_a = 8 steps, the preset's network): six episodes, split between
// two one-thread child processes (the default at 2 threads, core/evaluation.h's
// evaluate_rollouts_each) or run in this process on its 2 threads (...OneProcess). The policy is
// trained for a few steps on 3 expert episodes, so most rollouts run to the time limit T_L = 250:
// about 32 decisions each.
#include <benchmark/benchmark.h>
#include <spdlog/spdlog.h>

#include "app/experiments.h"
#include "core/evaluation.h"
#include "core/method.h"
#include "core/runtime.h"
#include "core/task_config.h"
#include "envs/registry.h"

namespace dd {
namespace {

struct Setup {
  ExperimentConfig config = preset("stack");
  std::unique_ptr<Env> env = make_env(config.task);
  std::unique_ptr<Method> method;
  Setup() {
    const std::vector<Episode> demos = app::collect_demos(config.task, config.expert, 3, 0);
    method = make_method("diff", config.policy, config.method, 0);
    TrainConfig t = config.train;
    t.steps = 50;
    method->update(demos, {}, t, {});
  }
};

Setup& setup() {
  static Setup s;
  return s;
}

void Rollouts(benchmark::State& state, bool two_processes) {
  Setup& s = setup();
  set_data_parallel(two_processes);
  const RolloutSpec spec = RolloutSpec::of(s.config.dagger);
  int decisions = 0;
  for (auto _ : state)
    for (const RolloutResult& r : evaluate_rollouts(*s.env, *s.method, 6, spec, 950000)) decisions += r.decisions;
  state.counters["decisions"] = benchmark::Counter(decisions, benchmark::Counter::kAvgIterations);
  set_data_parallel(true);
}

BENCHMARK_CAPTURE(Rollouts, two, true)->Name("BM_Rollouts_Stack")->Unit(benchmark::kSecond)->UseRealTime()->Iterations(1)->Repetitions(3);
BENCHMARK_CAPTURE(Rollouts, one, false)->Name("BM_RolloutsOneProcess_Stack")->Unit(benchmark::kSecond)->UseRealTime()->Iterations(1)->Repetitions(3);

}  // namespace
}  // namespace dd

int main(int argc, char** argv) {
  spdlog::set_level(spdlog::level::warn);
  dd::set_num_threads();
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  return 0;
}
