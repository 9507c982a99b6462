// import_diffusion_policy / export_diffusion_policy: diffusion_policy's ConditionalUnet1D names <->
// ours, the network's shape read from the weights, the rest from a JSON file (core/interop.h).
#include "core/interop.h"

#include <fstream>
#include <iterator>
#include <map>
#include <regex>
#include <set>

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <nlohmann/json.hpp>

#include "core/isolate.h"
#include "core/json_read.h"
#include "core/nn/archive_io.h"
#include "core/nn/policy_impl.h"
#include "core/text_file.h"

namespace dd {
namespace {

// A residual block's parameter (after the block's own name) in diffusion_policy's
// ConditionalResidualBlock1D: blocks.{0,1}.block.{0: Conv1d, 1: GroupNorm}, cond_encoder.1 (the FiLM
// Linear, after a Mish), residual_conv (1x1, when the channels change).
std::string res_block_name(const std::string& rest) {
  static const std::pair<const char*, const char*> kParts[] = {
      {"block0.conv.", "blocks.0.block.0."}, {"block0.norm.", "blocks.0.block.1."}, {"block1.conv.", "blocks.1.block.0."},
      {"block1.norm.", "blocks.1.block.1."}, {"film.", "cond_encoder.1."},          {"residual.", "residual_conv."}};
  for (const auto& [ours, theirs] : kParts) {
    const std::string prefix = ours;
    if (rest.compare(0, prefix.size(), prefix) == 0) return theirs + rest.substr(prefix.size());
  }
  throw Error("interop: no diffusion_policy name for the residual block parameter '" + rest + "'");
}

// Our parameter name -> diffusion_policy's. Levels: down_modules.I = [res, res, Downsample1d(.conv)],
// mid_modules = [res, res], up_modules.J = [res, res, Upsample1d(.conv)], final_conv = [Conv1dBlock,
// Conv1d]; the step encoder is Sequential(SinusoidalPosEmb, Linear, Mish, Linear).
std::string dp_name(const std::string& ours) {
  static const std::regex kRes(R"(^(down|up)(\d+)_res([01])\.(.+)$)");
  static const std::regex kSample(R"(^(down|up)(\d+)_sample\.(.+)$)");
  static const std::regex kMid(R"(^mid_res([01])\.(.+)$)");
  std::smatch m;
  if (std::regex_match(ours, m, kRes)) return fmt::format("{}_modules.{}.{}.{}", m[1].str(), m[2].str(), m[3].str(), res_block_name(m[4]));
  if (std::regex_match(ours, m, kSample)) return fmt::format("{}_modules.{}.2.conv.{}", m[1].str(), m[2].str(), m[3].str());
  if (std::regex_match(ours, m, kMid)) return fmt::format("mid_modules.{}.{}", m[1].str(), res_block_name(m[2]));
  static const std::pair<const char*, const char*> kTop[] = {{"step_fc1.", "diffusion_step_encoder.1."},
                                                             {"step_fc2.", "diffusion_step_encoder.3."},
                                                             {"final_block.conv.", "final_conv.0.block.0."},
                                                             {"final_block.norm.", "final_conv.0.block.1."},
                                                             {"final_conv.", "final_conv.1."}};
  for (const auto& [o, theirs] : kTop) {
    const std::string prefix = o;
    if (ours.compare(0, prefix.size(), prefix) == 0) return theirs + ours.substr(prefix.size());
  }
  throw Error("interop: no diffusion_policy name for the parameter '" + ours + "'");
}

std::string shape_of(const torch::Tensor& t) { return fmt::format("[{}]", fmt::join(t.sizes(), ", ")); }

// The file's dict of tensors. libtorch's in-memory zip reader overflows its buffer on some corrupt
// files (tests/fuzz), so a child process parses the file, checks it is a dict of named tensors and
// sends it back re-serialised by pickle_save; only that well-formed copy is parsed here.
std::map<std::string, torch::Tensor> read_state_dict(const std::string& path) {
  auto parse = [&path](const std::vector<char>& bytes) {
    c10::IValue value;
    try {
      value = torch::pickle_load(bytes);
    } catch (const c10::Error& e) {
      throw Error(path + ": not a state_dict that torch.load reads (truncated, corrupt, or pickled Python objects other "
                         "than tensors; save `dict(model.state_dict())`): " + first_line(e.what()));
    }
    if (!value.isGenericDict()) throw Error(path + ": holds a " + value.tagKind() + ", not a dict of tensors (a state_dict)");
    std::map<std::string, torch::Tensor> out;
    for (const auto& entry : value.toGenericDict()) {
      if (!entry.key().isString()) throw Error(path + ": a key of the state_dict is a " + entry.key().tagKind() + ", not a name");
      const std::string& key = entry.key().toStringRef();
      if (!entry.value().isTensor()) throw Error(path + ": '" + key + "' holds a " + entry.value().tagKind() + ", not a tensor");
      out[key] = entry.value().toTensor();
    }
    return out;
  };
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": cannot open the state_dict file");
  const std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string clean = read_in_child(path, "libtorch", [&] {
    c10::Dict<std::string, torch::Tensor> dict;
    for (const auto& [key, value] : parse(bytes)) dict.insert(key, value.contiguous());
    const std::vector<char> out = torch::pickle_save(c10::IValue(dict));
    return std::string(out.begin(), out.end());
  });
  return parse(std::vector<char>(clean.begin(), clean.end()));
}

Vec to_vec(const nlohmann::json& j, const std::string& field, const std::string& path) {
  if (!j.is_array()) throw Error(path + ": field '" + field + "' must be a list of numbers");
  Vec v(static_cast<Eigen::Index>(j.size()));
  for (size_t i = 0; i < j.size(); ++i) {
    if (!j[i].is_number()) throw Error(path + ": field '" + field + "' must be a list of numbers (entry " + std::to_string(i) + ")");
    v[static_cast<Eigen::Index>(i)] = j[i].get<float>();
    if (!std::isfinite(v[static_cast<Eigen::Index>(i)]))
      throw Error(path + ": field '" + field + "' entry " + std::to_string(i) + " is not finite");
  }
  return v;
}

template <typename T>
T field_or(const nlohmann::json& j, const char* field, T fallback, const std::string& path) {
  if (!j.contains(field)) return fallback;
  try {
    return json_read::get_checked<T>(j.at(field), path + ": field '" + field + "'");
  } catch (const Error&) {
    throw Error(path + ": field '" + field + "' has the wrong type or is out of range (" + j.at(field).dump() + ")");
  }
}

}  // namespace

std::unique_ptr<DiffusionPolicy> import_diffusion_policy(const std::string& sd_path, const std::string& json_path,
                                                         const PolicyConfig& defaults) {
  std::map<std::string, torch::Tensor> sd = read_state_dict(sd_path);

  // The network's keys may carry a prefix (a whole policy's state_dict has `model.`).
  const std::string anchor = "diffusion_step_encoder.1.weight";
  std::string prefix;
  bool found = false;
  for (const auto& [key, value] : sd) {
    if (key.size() >= anchor.size() && key.compare(key.size() - anchor.size(), anchor.size(), anchor) == 0) {
      prefix = key.substr(0, key.size() - anchor.size());
      found = true;
      break;
    }
  }
  if (!found) throw Error(sd_path + ": no key '" + anchor + "': not the state_dict of a diffusion_policy ConditionalUnet1D");
  auto get = [&](const std::string& name) -> const torch::Tensor& {
    const auto it = sd.find(prefix + name);
    if (it == sd.end()) throw Error(sd_path + ": missing key '" + prefix + name + "'");
    return it->second;
  };

  // The shape, from the weights.
  UnetConfig unet;
  const torch::Tensor& step1 = get("diffusion_step_encoder.1.weight");
  if (step1.dim() != 2) throw Error(sd_path + ": '" + prefix + anchor + "' has shape " + shape_of(step1) + ", not a Linear's");
  unet.step_embed_dim = static_cast<int>(step1.size(1));
  unet.down_dims.clear();
  int action_dim = 0;
  for (int i = 0; sd.count(fmt::format("{}down_modules.{}.0.blocks.0.block.0.weight", prefix, i)); ++i) {
    const torch::Tensor& w = sd.at(fmt::format("{}down_modules.{}.0.blocks.0.block.0.weight", prefix, i));
    if (w.dim() != 3) throw Error(fmt::format("{}: '{}down_modules.{}.0.blocks.0.block.0.weight' has shape {}, not a Conv1d's", sd_path, prefix, i, shape_of(w)));
    unet.down_dims.push_back(static_cast<int>(w.size(0)));
    if (i == 0) {
      action_dim = static_cast<int>(w.size(1));
      unet.kernel_size = static_cast<int>(w.size(2));
    }
  }
  if (unet.down_dims.empty()) throw Error(sd_path + ": missing key '" + prefix + "down_modules.0.0.blocks.0.block.0.weight'");
  const torch::Tensor& film = get("down_modules.0.0.cond_encoder.1.weight");
  if (film.dim() != 2 || film.size(0) != 2 * unet.down_dims[0])
    throw Error(fmt::format("{}: '{}down_modules.0.0.cond_encoder.1.weight' has shape {}, where a FiLM with scale and bias needs {} "
                            "rows: the network was trained without cond_predict_scale, which diffdagger does not run",
                            sd_path, prefix, shape_of(film), 2 * unet.down_dims[0]));
  const int global_cond = static_cast<int>(film.size(1)) - unet.step_embed_dim;
  if (global_cond <= 0)
    throw Error(sd_path + ": the network has no global condition: it was trained without obs_as_global_cond (inpainting), "
                          "which diffdagger does not run");

  // The rest, from the JSON.
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(read_text(json_path));
  } catch (const nlohmann::json::parse_error& e) {
    throw Error(json_path + ": not valid JSON: " + e.what());
  }
  if (!j.is_object()) throw Error(json_path + ": must be a JSON object");
  if (!j.contains("horizon")) throw Error(json_path + ": missing field 'horizon' (T_p, the chunk length the network was trained on)");
  const int n_obs_steps = field_or(j, "n_obs_steps", 1, json_path);
  if (n_obs_steps != 1)
    throw Error(json_path + ": field 'n_obs_steps' is " + std::to_string(n_obs_steps) + "; diffdagger conditions on one observation");
  if (field_or<std::string>(j, "beta_schedule", "squaredcos_cap_v2", json_path) != "squaredcos_cap_v2")
    throw Error(json_path + ": field 'beta_schedule' must be squaredcos_cap_v2, the only schedule diffdagger has");
  PolicyConfig c;
  c.obs_dim = global_cond;
  c.action_dim = action_dim;
  c.horizon = field_or(j, "horizon", 0, json_path);
  c.action_steps = field_or(j, "n_action_steps", defaults.action_steps, json_path);
  unet.n_groups = field_or(j, "n_groups", 8, json_path);
  if (j.contains("down_dims") && field_or<std::vector<int>>(j, "down_dims", {}, json_path) != unet.down_dims)
    throw Error(fmt::format("{}: field 'down_dims' says {}, the weights in {} have {}", json_path, j.at("down_dims").dump(), sd_path,
                            fmt::join(unet.down_dims, ",")));
  if (j.contains("kernel_size") && field_or(j, "kernel_size", 0, json_path) != unet.kernel_size)
    throw Error(fmt::format("{}: field 'kernel_size' says {}, the weights in {} have {}", json_path, j.at("kernel_size").dump(), sd_path,
                            unet.kernel_size));
  c.unet = unet;
  const std::string prediction = field_or<std::string>(j, "prediction_type", "epsilon", json_path);
  if (prediction == "epsilon") c.scheduler.prediction = PredictionType::kEpsilon;
  else if (prediction == "sample") c.scheduler.prediction = PredictionType::kSample;
  else if (prediction == "v_prediction") c.scheduler.prediction = PredictionType::kVelocity;
  else throw Error(json_path + ": field 'prediction_type' is '" + prediction + "', not one of epsilon, sample, v_prediction");
  c.scheduler.num_train_timesteps = field_or(j, "num_train_timesteps", 100, json_path);
  c.scheduler.num_inference_steps = field_or(j, "num_inference_steps", c.scheduler.num_train_timesteps, json_path);
  c.scheduler.clip_sample = field_or(j, "clip_sample", true, json_path);
  c.scheduler.sampler = SamplerType::kDdpm;
  if (c.obs_dim != defaults.obs_dim || c.action_dim != defaults.action_dim)
    throw Error(fmt::format("{}: the network takes {} observation and {} action features per step; this task has {} and {}", sd_path,
                            c.obs_dim, c.action_dim, defaults.obs_dim, defaults.action_dim));
  try {
    c.validate();
  } catch (const Error& e) {
    throw Error(json_path + ": " + e.what());
  }

  auto policy = std::make_unique<DiffusionPolicy>(c, 0, /*announce=*/false);
  DiffusionPolicy::Impl& impl = policy->impl();
  std::set<std::string> used;
  {
    torch::NoGradGuard no_grad;
    for (auto& p : impl.model->named_parameters()) {
      const std::string name = dp_name(p.key());
      const torch::Tensor& src = get(name);
      if (src.sizes() != p.value().sizes())
        throw Error(fmt::format("{}: '{}{}' has shape {}, where this ConditionalUnet1D (down_dims {}, kernel {}) needs {}", sd_path, prefix,
                                name, shape_of(src), fmt::join(unet.down_dims, ","), unet.kernel_size, shape_of(p.value())));
      if (!torch::isfinite(src).all().item<bool>()) throw Error(sd_path + ": '" + prefix + name + "' holds NaN or infinite weights");
      p.value().copy_(src.to(torch::kFloat32));
      used.insert(prefix + name);
    }
  }
  impl.copy_model_to_ema();
  for (auto& p : impl.ema->parameters()) p.set_requires_grad(false);

  // The normalizer: the JSON's, else a whole policy's state_dict's.
  auto from_dict = [&](const std::string& key, const char* part) -> Vec {
    const std::string name = "normalizer.params_dict." + key + "." + part;
    const auto it = sd.find(name);
    if (it == sd.end()) throw Error(json_path + ": no normalizer: missing field '" + key + "' (and " + sd_path + " has no '" + name + "')");
    used.insert(name);
    const torch::Tensor t = it->second.to(torch::kFloat32).contiguous().view(-1);
    return Eigen::Map<const Vec>(t.data_ptr<float>(), t.numel());
  };
  auto normalizer = [&](const std::string& key, int dim) {
    Vec scale, offset;
    if (j.contains(key)) {
      const nlohmann::json& n = j.at(key);
      if (!n.is_object() || !n.contains("scale") || !n.contains("offset"))
        throw Error(json_path + ": field '" + key + "' must hold 'scale' and 'offset' (diffusion_policy's LinearNormalizer params)");
      scale = to_vec(n.at("scale"), key + ".scale", json_path);
      offset = to_vec(n.at("offset"), key + ".offset", json_path);
    } else {
      scale = from_dict(key, "scale");
      offset = from_dict(key, "offset");
    }
    if (scale.size() != dim || offset.size() != dim)
      throw Error(fmt::format("{}: field '{}' has {} scales and {} offsets; the network has {} features", json_path, key, scale.size(),
                              offset.size(), dim));
    return Normalizer::from_params(scale, offset);
  };
  policy->set_normalizers(normalizer("obs", c.obs_dim), normalizer("action", c.action_dim));

  // Whatever is left is a network diffdagger does not have (local conditioning, an image encoder, ...);
  // the normalizer's input_stats are not needed.
  std::vector<std::string> unexpected;
  for (const auto& [key, value] : sd) {
    if (!used.count(key) && key.rfind("normalizer.", 0) != 0) unexpected.push_back(key);
  }
  if (!unexpected.empty()) {
    if (unexpected.size() > 5) unexpected.resize(5), unexpected.push_back("...");
    throw Error(fmt::format("{}: keys a ConditionalUnet1D with cond_predict_scale and no local conditioning does not have: {}", sd_path,
                            fmt::join(unexpected, ", ")));
  }
  impl.weights_changed();
  return policy;
}

void export_diffusion_policy(const DiffusionPolicy& policy, const std::string& sd_path, const std::string& json_path) {
  const PolicyConfig& c = policy.config();
  if (!c.relative_actions.empty())
    throw Error("export: the policy's actions are relative to its observations (relative_actions), which diffusion_policy does not do");
  if (c.action_norm_per_step) throw Error("export: the policy normalises each chunk step's actions on its own (action_norm_per_step), "
                                          "which diffusion_policy's LinearNormalizer does not do");
  if (c.scheduler.sampler != SamplerType::kDdpm) throw Error("export: the policy samples with DDIM; diffusion_policy's lowdim default is DDPM");
  const DiffusionPolicy::Impl& impl = policy.impl();
  c10::Dict<std::string, torch::Tensor> dict;
  for (const auto& p : impl.ema->named_parameters()) dict.insert(dp_name(p.key()), p.value().detach().clone().contiguous());
  std::vector<char> bytes;
  try {
    bytes = torch::pickle_save(c10::IValue(dict));
  } catch (const c10::Error& e) {
    throw Error(sd_path + ": could not serialise the state_dict: " + first_line(e.what()));
  }
  write_text(sd_path, std::string(bytes.begin(), bytes.end()));

  auto params = [](const Normalizer& n) {
    return nlohmann::json{{"scale", std::vector<float>(n.scale().data(), n.scale().data() + n.scale().size())},
                          {"offset", std::vector<float>(n.offset().data(), n.offset().data() + n.offset().size())}};
  };
  const nlohmann::json j = {{"obs", params(impl.obs_norm)},
                            {"action", params(impl.act_norm)},
                            {"horizon", c.horizon},
                            {"n_action_steps", c.action_steps},
                            {"n_obs_steps", 1},
                            {"prediction_type", to_string(c.scheduler.prediction)},
                            {"num_train_timesteps", c.scheduler.num_train_timesteps},
                            {"num_inference_steps", c.scheduler.num_inference_steps},
                            {"beta_schedule", "squaredcos_cap_v2"},
                            {"clip_sample", c.scheduler.clip_sample},
                            {"n_groups", c.unet.n_groups},
                            {"down_dims", c.unet.down_dims},
                            {"kernel_size", c.unet.kernel_size},
                            {"diffusion_step_embed_dim", c.unet.step_embed_dim}};
  write_text(json_path, j.dump(2) + "\n");
}

}  // namespace dd
