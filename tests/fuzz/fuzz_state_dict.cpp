// libFuzzer: import-policy's two inputs. An input that starts with '{' is the JSON (normalizer and
// settings), read with a valid state_dict; any other is the state_dict, read with a valid JSON. The
// valid pair is a micro network's, written at start-up; with DD_FUZZ_SEEDS=DIR set, the harness
// writes that pair into DIR as seeds and exits.
#include <cstdlib>
#include <filesystem>

#include "core/interop.h"
#include "core/policy.h"
#include "tests/fuzz/fuzz_common.h"

namespace {

dd::PolicyConfig micro() { return dd::fuzz::micro_policy(); }

std::string g_sd, g_json;

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  g_sd = dd::fuzz::scratch_path("valid_sd.pt");
  g_json = dd::fuzz::scratch_path("valid.json");
  dd::DiffusionPolicy policy(micro(), 0, /*announce=*/false);
  dd::export_diffusion_policy(policy, g_sd, g_json);
  if (const char* dir = dd::fuzz::seed_dir()) {
    std::filesystem::create_directories(dir);
    std::filesystem::copy_file(g_sd, std::string(dir) + "/micro_state_dict.pt", std::filesystem::copy_options::overwrite_existing);
    std::filesystem::copy_file(g_json, std::string(dir) + "/micro.json", std::filesystem::copy_options::overwrite_existing);
    std::exit(0);
  }
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const bool json = size > 0 && data[0] == '{';
  const std::string path = dd::fuzz::input_file(data, size, json ? "input.json" : "input_sd.pt");
  dd::fuzz::expect_clean([&] {
    const auto policy = dd::import_diffusion_policy(json ? g_sd : path, json ? path : g_json, micro());
    policy->sample(dd::Vec::Zero(4), 0);
  });
  return 0;
}
