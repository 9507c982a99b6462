// Saving libtorch archives (policy checkpoints, trainer states) the same careful way. Includes torch:
// only for the .cpp files that already do.
#pragma once

#include <string>
#include <vector>

#include <torch/torch.h>

#include "core/normalizer.h"
#include "core/types.h"

namespace dd {

/// The first line of a torch error: the rest is a C++ backtrace nobody wants to read.
std::string first_line(const std::string& s);

/// archive.load_from(path), after the same load succeeded in a child process (core/isolate.h):
/// libtorch's zip reader overflows its buffers on some corrupt files. Throws Error "path: no such
/// <what> file" or "path: not a readable <what> (truncated or corrupt): ...", or names the crash.
void load_archive_checked(torch::serialize::InputArchive& archive, const std::string& path, const std::string& what);

/// Throws Error naming the file and field when a loaded tensor's view reaches outside its storage
/// (a corrupt archive; tests/fuzz found one that threw from inside libtorch at the first use) or,
/// for floating-point tensors, holds NaN or infinite values.
void check_tensor(const torch::Tensor& t, const std::string& path, const std::string& name);
/// One network of a file: `module` is loaded from `archive`, its tensors named prefix + their name.
struct ModulePart {
  torch::nn::Module& module;
  torch::serialize::InputArchive& archive;
  std::string prefix;
};
/// Loads every part, all or nothing. Module::load takes a stored tensor whatever its shape, so each
/// parameter and buffer must then keep the shape and type the module was built with (else Error
/// "path: field 'model.x.weight' is [8, 2, 3] Float where the network its config describes has
/// [8, 2, 99] Float"; the fast paths would read past it) and pass check_tensor(). A non-contiguous
/// tensor is made contiguous. On any failure, c10::Error included, every part keeps what it held.
void load_modules_checked(const std::vector<ModulePart>& parts, const std::string& path);

/// A vector as a 1-D float tensor (a copy) and back: normalisers in archives.
torch::Tensor vec_tensor(const Vec& v);
Vec tensor_vec(const torch::Tensor& t);

/// A policy's or critic's two normalisers, as fields obs_scale, obs_offset, act_scale, act_offset.
void write_normalizers(torch::serialize::OutputArchive& archive, const Normalizer& obs, const Normalizer& action);
/// Reads write_normalizers()'s fields and checks them (check_tensor, and sizes obs_dim and
/// action_dim: else Error "path: normaliser sizes (fields obs_scale, act_scale) do not match <owner>").
/// Torch's own errors (a missing field) pass through as c10::Error for the caller's message.
std::pair<Normalizer, Normalizer> read_normalizers(torch::serialize::InputArchive& archive, const std::string& path, int obs_dim,
                                                   int action_dim, const std::string& owner);

/// Writes `archive` to path + ".tmp" and renames it to `path`, so a failed save (a full disk) never
/// clobbers a good file. Throws Error "path: could not write <what>: ..." on failure.
void save_archive_atomically(torch::serialize::OutputArchive& archive, const std::string& path, const std::string& what);

}  // namespace dd
