// libFuzzer: data sets (train --data, dataset info|export|merge, a session's saved state).
#include <filesystem>

#include "core/dataset.h"
#include "tests/fuzz/fuzz_common.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  if (const char* dir = dd::fuzz::seed_dir()) {  // two short episodes, one with an intervention
    std::filesystem::create_directories(dir);
    const std::string path = std::string(dir) + "/two_episodes.hdf5";
    std::filesystem::remove(path);
    dd::DatasetWriter writer(path, R"({"env_name": "nav2d", "type": "diffdagger", "env_kwargs": {}})");
    for (int e = 0; e < 2; ++e) {
      dd::RecordedEpisode ep;
      ep.obs = dd::Mat::Random(5, 4);
      ep.actions = dd::Mat::Random(5, 2);
      ep.success = e == 0;
      ep.intervention = {0, 0, static_cast<uint8_t>(e), static_cast<uint8_t>(e), 0};
      ep.actor = {0, 0, static_cast<uint8_t>(e), static_cast<uint8_t>(e), 0};
      ep.source = e == 0 ? "expert" : "intervention";
      writer.append(ep);
    }
    std::exit(0);
  }
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = dd::fuzz::input_file(data, size, "data.hdf5");
  dd::fuzz::expect_clean([&] {
    dd::DatasetInfo info;
    for (const dd::RecordedEpisode& e : dd::read_dataset(path, &info)) e.expert_steps();
  });
  return 0;
}
