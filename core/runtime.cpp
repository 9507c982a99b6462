#include "core/runtime.h"

#include <ATen/Parallel.h>

#include <algorithm>
#include <atomic>
#include <mutex>
#include <cstdlib>
#include <string_view>
#include <thread>

// Weak: a program without OpenMP has no pool to set.
extern "C" void omp_set_num_threads(int) __attribute__((weak));

namespace dd {

int set_num_threads(int n) {
  if (n <= 0) {
    const char* env = std::getenv("DD_THREADS");
    n = env ? std::atoi(env) : 0;
  }
  if (n <= 0) n = std::clamp(static_cast<int>(std::thread::hardware_concurrency()), 1, 2);
  at::set_num_threads(n);
  return n;
}

int num_threads() { return at::get_num_threads(); }

void set_openmp_threads(int n) {
  if (omp_set_num_threads) omp_set_num_threads(n);
}

namespace {
std::atomic<bool> g_data_parallel{true};
}

void set_data_parallel(bool on) { g_data_parallel = on; }

bool set_data_parallel_from(bool one_process) {
  const char* env = std::getenv("DD_ONE_PROCESS");
  const bool env_off = env && *env && std::string_view(env) != "0";
  set_data_parallel(!one_process && !env_off);
  return g_data_parallel;
}
namespace {
std::mutex g_cache_mutex;
std::string g_ensemble_cache;
}  // namespace

void set_ensemble_train_cache(const std::string& dir) {
  std::lock_guard<std::mutex> lock(g_cache_mutex);
  g_ensemble_cache = dir;
}
std::string ensemble_train_cache() {
  std::lock_guard<std::mutex> lock(g_cache_mutex);
  return g_ensemble_cache;
}

bool split_in_two_processes() { return g_data_parallel && at::get_num_threads() >= 2 && !at::in_parallel_region(); }

}  // namespace dd
