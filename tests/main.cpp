// Shared test main: quiet logging, one libtorch thread unless DD_THREADS says otherwise.
#include <gtest/gtest.h>
#include <spdlog/spdlog.h>

#include "core/runtime.h"

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  spdlog::set_level(spdlog::level::warn);
  dd::set_num_threads();
  return RUN_ALL_TESTS();
}
