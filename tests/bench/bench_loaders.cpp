// What reading a file in a child process (core/isolate.h) costs: a data set of 50 nav2d-sized
// episodes read as the loaders read it (HDF5 in a child, episodes sent back through a pipe) against
// the fork alone, and a bare fork with a trivial reader. Run with the policy libraries loaded, as a
// real process has them (the fork copies the page tables of everything mapped).
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <filesystem>

#include "core/dataset.h"
#include "core/isolate.h"
#include "core/policy.h"

namespace {

std::string dataset_file() {
  static const std::string path = [] {
    const std::string p = std::filesystem::temp_directory_path() / ("dd_bench_loaders_" + std::to_string(::getpid()) + ".hdf5");
    std::filesystem::remove(p);
    std::vector<dd::RecordedEpisode> eps(50);
    for (auto& e : eps) {
      e.obs = dd::Mat::Random(60, 4);
      e.actions = dd::Mat::Random(60, 2);
    }
    dd::write_dataset(p, "{}", eps);
    return p;
  }();
  return path;
}

void ReadDataset(benchmark::State& state) {
  const std::string path = dataset_file();
  for (auto _ : state) benchmark::DoNotOptimize(dd::read_dataset(path));
}
BENCHMARK(ReadDataset)->Unit(benchmark::kMillisecond);

void ForkOnly(benchmark::State& state) {
  for (auto _ : state) benchmark::DoNotOptimize(dd::read_in_child("none", "nothing", [] { return std::string("x"); }));
}
BENCHMARK(ForkOnly)->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) {
  dd::PolicyConfig c;  // a policy in memory, as in a real run: libtorch mapped and initialised
  const dd::DiffusionPolicy policy(c, 0, /*announce=*/false);
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  std::filesystem::remove(dataset_file());
  return 0;
}
