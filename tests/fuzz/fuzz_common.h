// What every harness shares: the input as a file (the loaders take paths, as users give them), and
// the rule that bad input may only end in a dd::Error; any other exception escaping the loader is a
// finding (libFuzzer reports it as a crash), as are sanitizer reports, hangs and runaway memory.
#pragma once

#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <string>

#include "core/config.h"

namespace dd::fuzz {

/// The network of the seed checkpoints and state_dicts: small enough for inputs of a few kB.
inline PolicyConfig micro_policy() {
  PolicyConfig c;
  c.obs_dim = 4;
  c.action_dim = 2;
  c.horizon = 4;
  c.action_steps = 2;
  c.unet.down_dims = {8, 8};
  c.unet.kernel_size = 3;
  c.unet.n_groups = 4;
  c.unet.step_embed_dim = 4;
  c.scheduler.num_train_timesteps = 4;
  c.scheduler.num_inference_steps = 4;
  return c;
}

/// With DD_FUZZ_SEEDS=DIR set, a harness writes its seed inputs into DIR and exits (run.sh --seeds).
inline const char* seed_dir() { return std::getenv("DD_FUZZ_SEEDS"); }

/// A path of this process's own under /dev/shm (else TMPDIR or /tmp), ending in `ext`.
inline std::string scratch_path(const std::string& name) {
  const char* dir = ::access("/dev/shm", W_OK) == 0 ? "/dev/shm" : (std::getenv("TMPDIR") ? std::getenv("TMPDIR") : "/tmp");
  return std::string(dir) + "/dd_fuzz_" + std::to_string(::getpid()) + "_" + name;
}

/// Writes the input to the scratch file `name` and returns its path.
inline std::string input_file(const uint8_t* data, size_t size, const std::string& name) {
  const std::string path = scratch_path(name);
  std::ofstream(path, std::ios::binary | std::ios::trunc).write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return path;
}

/// Runs the loader; a dd::Error (a clear message) is the expected end of bad input.
template <typename F>
void expect_clean(F&& load) {
  try {
    load();
  } catch (const dd::Error&) {
  }
}

}  // namespace dd::fuzz
