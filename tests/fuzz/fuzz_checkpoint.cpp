// libFuzzer: policy checkpoints (inspect, train --init, gui --policy, render --policy, resume points).
#include <filesystem>

#include "core/policy.h"
#include "tests/fuzz/fuzz_common.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  if (const char* dir = dd::fuzz::seed_dir()) {
    std::filesystem::create_directories(dir);
    dd::DiffusionPolicy(dd::fuzz::micro_policy(), 0, /*announce=*/false).save(std::string(dir) + "/micro_policy.pt");
    std::exit(0);
  }
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = dd::fuzz::input_file(data, size, "policy.pt");
  dd::fuzz::expect_clean([&] {
    const auto policy = dd::DiffusionPolicy::from_checkpoint(path);
    // a checkpoint that loads must also act: one chunk from a zero observation
    policy->sample(dd::Vec::Zero(policy->config().obs_dim), 0);
  });
  return 0;
}
