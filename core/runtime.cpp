#include "core/runtime.h"

#include <ATen/Parallel.h>

#include <algorithm>
#include <cstdlib>
#include <thread>

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

}  // namespace dd
