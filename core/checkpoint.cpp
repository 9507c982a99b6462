// DiffusionPolicy::save / load / from_checkpoint.
//
// One file, torch's archive format (a zip): "format" and "version" tags, "config" (the PolicyConfig as
// JSON), the four normaliser vectors, and the "model" and "ema" weights as sub-archives. Writing goes
// through a temporary file and a rename, so a failed save (a full disk) never clobbers a good file.
#include <filesystem>
#include <fstream>
#include <sstream>

#include <nlohmann/json.hpp>

#include "core/nn/archive_io.h"
#include "core/nn/policy_impl.h"

namespace dd {
namespace {

constexpr const char* kFormat = "diffdagger-policy";
constexpr int64_t kVersion = 1;

struct Contents {
  PolicyConfig config;
  torch::serialize::InputArchive archive;
};

// Opens and checks the format tag and config of a checkpoint file.
void open_checkpoint(const std::string& path, Contents& out) {
  load_archive_checked(out.archive, path, "checkpoint");
  c10::IValue format, version, config;
  if (!out.archive.try_read("format", format) || !format.isString() || format.toStringRef() != kFormat)
    throw Error(path + ": not a diffdagger policy checkpoint (missing field 'format')");
  if (!out.archive.try_read("version", version) || !version.isInt() || version.toInt() != kVersion)
    throw Error(path + ": unsupported checkpoint version (field 'version')");
  if (!out.archive.try_read("config", config) || !config.isString())
    throw Error(path + ": checkpoint has no field 'config'");
  out.config = policy_config_from_json(config.toStringRef(), path + " (field 'config')");
  // A corrupt config can describe a network of terabytes: before one is built to load into, the file
  // must be large enough to hold its weights (float32, the model's and the EMA's).
  const int64_t n = nn::parameter_count(out.config.action_dim, out.config.obs_dim, out.config.unet);
  const double need = 2.0 * sizeof(float) * static_cast<double>(n);
  const auto size = std::filesystem::file_size(path);
  if (need > static_cast<double>(size))
    throw Error(path + ": field 'config' describes a network of " + std::to_string(n) + " parameters (" +
                std::to_string(static_cast<int64_t>(need / 1e6)) + " MB of weights with its EMA copy), more than the whole file (" +
                std::to_string(size) + " bytes) holds");
}

void read_into(const std::string& path, Contents& c, DiffusionPolicy::Impl& impl) {
  try {
    auto [obs_norm, act_norm] = read_normalizers(c.archive, path, c.config.obs_dim, c.config.action_norm_dim(), "the stored config");
    torch::serialize::InputArchive model, ema;
    c.archive.read("model", model);
    c.archive.read("ema", ema);
    load_modules_checked({{*impl.model, model, "model."}, {*impl.ema, ema, "ema."}}, path);
    impl.obs_norm = std::move(obs_norm);
    impl.act_norm = std::move(act_norm);
  } catch (const c10::Error& e) {
    throw Error(path + ": checkpoint weights are incomplete or do not fit the network: " + first_line(e.what()));
  }
  for (auto& p : impl.ema->parameters()) p.set_requires_grad(false);
  impl.weights_changed();
}

}  // namespace

namespace {
void write_checkpoint(const DiffusionPolicy::Impl& impl, torch::serialize::OutputArchive& archive) {
  archive.write("format", c10::IValue(std::string(kFormat)));
  archive.write("version", c10::IValue(kVersion));
  archive.write("config", c10::IValue(nlohmann::json(impl.config).dump()));
  write_normalizers(archive, impl.obs_norm, impl.act_norm);
  torch::serialize::OutputArchive model, ema;
  impl.model->save(model);
  impl.ema->save(ema);
  archive.write("model", model);
  archive.write("ema", ema);
}
}  // namespace

void DiffusionPolicy::save(const std::string& path) const {
  torch::serialize::OutputArchive archive;
  write_checkpoint(*impl_, archive);
  save_archive_atomically(archive, path, "checkpoint");
}

std::string DiffusionPolicy::checkpoint_bytes() const {
  torch::serialize::OutputArchive archive;
  write_checkpoint(*impl_, archive);
  std::ostringstream out;
  archive.save_to(out);
  return out.str();
}

void DiffusionPolicy::load(const std::string& path) {
  Contents c;
  open_checkpoint(path, c);
  const std::vector<std::string> diffs = config_differences(c.config, impl_->config);
  if (!diffs.empty()) {
    std::string msg = path + ": checkpoint does not match this policy's config (checkpoint vs policy):";
    for (const auto& d : diffs) msg += "\n  " + d;
    throw Error(msg);
  }
  read_into(path, c, *impl_);
}

std::unique_ptr<DiffusionPolicy> DiffusionPolicy::from_checkpoint(const std::string& path) {
  Contents c;
  open_checkpoint(path, c);
  auto policy = std::make_unique<DiffusionPolicy>(c.config, 0);
  read_into(path, c, policy->impl());
  return policy;
}

}  // namespace dd
