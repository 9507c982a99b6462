// libFuzzer: experiment config YAML (dagger/eval/train/gui --config FILE).
#include "core/task_config.h"
#include "tests/fuzz/fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = dd::fuzz::input_file(data, size, "config.yaml");
  dd::fuzz::expect_clean([&] { dd::load_experiment_config(path).validate(); });
  return 0;
}
