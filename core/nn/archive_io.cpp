#include "core/nn/archive_io.h"

#include <filesystem>

#include "core/config.h"
#include "core/isolate.h"

namespace dd {

std::string first_line(const std::string& s) { return s.substr(0, s.find('\n')); }

void load_archive_checked(torch::serialize::InputArchive& archive, const std::string& path, const std::string& what) {
  if (!std::filesystem::exists(path)) throw Error(path + ": no such " + what + " file");
  auto load = [&](torch::serialize::InputArchive& a) {
    try {
      a.load_from(path);
    } catch (const c10::Error& e) {
      throw Error(path + ": not a readable " + what + " (truncated or corrupt): " + first_line(e.what()));
    } catch (const std::exception& e) {  // TorchScript's parser throws std::runtime_error (tests/fuzz --deep)
      throw Error(path + ": not a readable " + what + " (corrupt): " + first_line(e.what()));
    }
  };
  read_in_child(path, "libtorch", [&] {
    torch::serialize::InputArchive a;
    load(a);
    return std::string();
  });
  load(archive);
}

void save_archive_atomically(torch::serialize::OutputArchive& archive, const std::string& path, const std::string& what) {
  const std::string tmp = path + ".tmp";
  std::error_code ec;
  try {
    archive.save_to(tmp);
  } catch (const c10::Error& e) {
    std::filesystem::remove(tmp, ec);
    throw Error(path + ": could not write " + what + ": " + first_line(e.what()));
  }
  std::filesystem::rename(tmp, path, ec);
  if (ec) {
    std::filesystem::remove(tmp, ec);
    throw Error(path + ": could not move " + what + " into place: " + ec.message());
  }
}

void check_tensor(const torch::Tensor& t, const std::string& path, const std::string& name) {
  if (!t.defined()) throw Error(path + ": field '" + name + "' holds no tensor");
  if (t.numel() > 0) {
    // the view must lie inside its storage: a corrupt archive can say otherwise, and the first
    // operation on the tensor then throws from deep inside libtorch (or reads outside the buffer)
    int64_t last = t.storage_offset();
    for (int64_t d = 0; d < t.dim(); ++d) {
      if (t.stride(d) < 0) throw Error(path + ": field '" + name + "' has a negative stride (corrupt)");
      last += (t.size(d) - 1) * t.stride(d);
    }
    const auto capacity = static_cast<int64_t>(t.storage().nbytes() / t.element_size());
    if (t.storage_offset() < 0 || last >= capacity)
      throw Error(path + ": field '" + name + "' reaches past its data (element " + std::to_string(last) + " of " +
                  std::to_string(capacity) + "): the file is corrupt");
    if (t.is_floating_point() && !torch::isfinite(t).all().item<bool>())
      throw Error(path + ": field '" + name + "' holds NaN or infinite values");
  }
}

namespace {
std::string shape_string(const torch::Tensor& t) {
  std::string s;
  for (const int64_t d : t.sizes()) s += (s.empty() ? "" : ", ") + std::to_string(d);
  return "[" + s + "] " + std::string(c10::toString(t.scalar_type()));
}
}  // namespace

void load_modules_checked(const std::vector<ModulePart>& parts, const std::string& path) {
  // the modules' tensors (handles: Module::load replaces their data in place, whatever its shape),
  // and copies of what they held, to check the shapes against and to put back on failure
  struct Slot {
    std::string name;
    torch::Tensor tensor, before;
  };
  std::vector<Slot> slots;
  for (const ModulePart& part : parts) {
    for (const auto& p : part.module.named_parameters()) slots.push_back({part.prefix + p.key(), p.value(), p.value().detach().clone()});
    for (const auto& b : part.module.named_buffers()) slots.push_back({part.prefix + b.key(), b.value(), b.value().detach().clone()});
  }
  try {
    for (const ModulePart& part : parts) part.module.load(part.archive);
    for (Slot& s : slots) {
      check_tensor(s.tensor, path, s.name);
      if (s.tensor.sizes() != s.before.sizes() || s.tensor.scalar_type() != s.before.scalar_type())
        throw Error(path + ": field '" + s.name + "' is " + shape_string(s.tensor) + " where the network its config describes has " +
                    shape_string(s.before));
      if (!s.tensor.is_contiguous()) {  // the fast paths read weights as dense arrays
        torch::NoGradGuard no_grad;
        s.tensor.set_(s.tensor.contiguous());
      }
    }
  } catch (...) {
    torch::NoGradGuard no_grad;
    for (Slot& s : slots) s.tensor.set_(s.before);
    throw;
  }
}

torch::Tensor vec_tensor(const Vec& v) {
  return torch::from_blob(const_cast<float*>(v.data()), {v.size()}, torch::kFloat32).clone();
}

Vec tensor_vec(const torch::Tensor& t) {
  const torch::Tensor c = t.contiguous().to(torch::kFloat32);
  return Eigen::Map<const Vec>(c.data_ptr<float>(), c.numel());
}

void write_normalizers(torch::serialize::OutputArchive& archive, const Normalizer& obs, const Normalizer& action) {
  archive.write("obs_scale", vec_tensor(obs.scale()));
  archive.write("obs_offset", vec_tensor(obs.offset()));
  archive.write("act_scale", vec_tensor(action.scale()));
  archive.write("act_offset", vec_tensor(action.offset()));
}

std::pair<Normalizer, Normalizer> read_normalizers(torch::serialize::InputArchive& archive, const std::string& path, int obs_dim,
                                                   int action_dim, const std::string& owner) {
  torch::Tensor os, oo, as, ao;
  archive.read("obs_scale", os);
  archive.read("obs_offset", oo);
  archive.read("act_scale", as);
  archive.read("act_offset", ao);
  if (os.numel() != obs_dim || oo.numel() != obs_dim || as.numel() != action_dim || ao.numel() != action_dim)
    throw Error(path + ": normaliser sizes (fields obs_scale, act_scale) do not match " + owner);
  for (const auto& [name, t] : {std::pair<const char*, const torch::Tensor&>{"obs_scale", os}, {"obs_offset", oo}, {"act_scale", as},
                                {"act_offset", ao}})
    check_tensor(t, path, name);
  return {Normalizer::from_params(tensor_vec(os), tensor_vec(oo)), Normalizer::from_params(tensor_vec(as), tensor_vec(ao))};
}

}  // namespace dd
