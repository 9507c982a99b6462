#include "core/config.h"

#include <algorithm>
#include <set>

#include <nlohmann/json.hpp>

#include "core/json_read.h"

namespace dd {
namespace {

using nlohmann::json;

using json_read::read;
using json_read::require_known_keys;

void check(bool ok, const std::string& field, const std::string& why) {
  if (!ok) throw Error(field + ": " + why);
}

}  // namespace

std::string to_string(PredictionType p) {
  switch (p) {
    case PredictionType::kEpsilon: return "epsilon";
    case PredictionType::kSample: return "sample";
    case PredictionType::kVelocity: return "v_prediction";
  }
  return "?";
}

std::string to_string(SamplerType s) { return s == SamplerType::kDdpm ? "ddpm" : "ddim"; }

static PredictionType prediction_from_string(const std::string& s) {
  if (s == "epsilon") return PredictionType::kEpsilon;
  if (s == "sample") return PredictionType::kSample;
  if (s == "v_prediction" || s == "v") return PredictionType::kVelocity;
  throw Error("scheduler.prediction: '" + s + "' is not one of epsilon, sample, v_prediction");
}

static SamplerType sampler_from_string(const std::string& s) {
  if (s == "ddpm") return SamplerType::kDdpm;
  if (s == "ddim") return SamplerType::kDdim;
  throw Error("scheduler.sampler: '" + s + "' is not one of ddpm, ddim");
}

UnetConfig unet_preset(const std::string& name) {
  UnetConfig c;
  if (name == "cpu" || name == "default") return c;
  if (name == "tiny") {
    c.down_dims = {16, 32, 64};
    c.step_embed_dim = 32;
    return c;
  }
  if (name == "medium") {
    c.down_dims = {64, 128, 256};
    c.step_embed_dim = 128;
    return c;
  }
  if (name == "paper") {
    c.down_dims = {256, 512, 1024};
    c.step_embed_dim = 128;
    return c;
  }
  throw Error("unet preset '" + name + "' is not one of tiny, cpu, medium, paper");
}

// Upper bounds far beyond any network this project trains (the paper's is down_dims 256,512,1024,
// kernel 5, T_p 16). They keep every size computed from a config inside int, and make a corrupt
// checkpoint's config an Error here rather than an allocation of terabytes (tests/fuzz found both).
namespace limits {
constexpr int kObsDim = 1 << 16, kActionDim = 1 << 10, kHorizon = 1 << 12, kLevels = 8, kChannels = 1 << 14,
              kGroups = 1 << 10, kKernel = 63, kStepEmbed = 1 << 14;
}

void PolicyConfig::validate() const {
  const auto in = [](int v, int lo, int hi) { return v >= lo && v <= hi; };
  const auto range = [](int lo, int hi) { return "must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]"; };
  check(in(obs_dim, 1, limits::kObsDim), "obs_dim", range(1, limits::kObsDim));
  check(in(action_dim, 1, limits::kActionDim), "action_dim", range(1, limits::kActionDim));
  check(in(horizon, 1, limits::kHorizon), "horizon", range(1, limits::kHorizon));
  check(action_steps > 0 && action_steps <= horizon, "action_steps", "must be in [1, horizon]");
  std::vector<bool> relative(static_cast<size_t>(action_dim), false);
  for (const auto& [a, o] : relative_actions) {
    check(a >= 0 && a < action_dim && o >= 0 && o < obs_dim, "relative_actions",
          "pair [" + std::to_string(a) + ", " + std::to_string(o) + "] is not [action index < action_dim, observation index < obs_dim]");
    check(!relative[static_cast<size_t>(a)], "relative_actions", "action index " + std::to_string(a) + " appears twice");
    relative[static_cast<size_t>(a)] = true;
  }
  // n_groups and the number of levels first: the checks below divide and shift by them
  check(in(unet.n_groups, 1, limits::kGroups), "unet.n_groups", range(1, limits::kGroups));
  const int levels = static_cast<int>(unet.down_dims.size());
  check(in(levels, 1, limits::kLevels), "unet.down_dims", "must have 1 to " + std::to_string(limits::kLevels) + " entries");
  check(horizon % (1 << (levels - 1)) == 0, "horizon",
        "must be divisible by 2^(levels-1) = " + std::to_string(1 << (levels - 1)));
  for (int d : unet.down_dims) {
    check(in(d, 1, limits::kChannels) && d % unet.n_groups == 0, "unet.down_dims",
          "every entry must be a multiple of n_groups (" + std::to_string(unet.n_groups) + ") in [1, " +
              std::to_string(limits::kChannels) + "]");
  }
  check(in(unet.kernel_size, 1, limits::kKernel) && unet.kernel_size % 2 == 1, "unet.kernel_size",
        "must be odd and in [1, " + std::to_string(limits::kKernel) + "]");
  check(in(unet.step_embed_dim, 2, limits::kStepEmbed) && unet.step_embed_dim % 2 == 0, "unet.step_embed_dim",
        "must be even and in [2, " + std::to_string(limits::kStepEmbed) + "]");
  check(scheduler.num_train_timesteps >= 1 && scheduler.num_train_timesteps <= 1000,
        "scheduler.num_train_timesteps", "must be in [1, 1000]");
  check(scheduler.num_inference_steps >= 1 &&
            scheduler.num_inference_steps <= scheduler.num_train_timesteps,
        "scheduler.num_inference_steps", "must be in [1, num_train_timesteps]");
}

void TrainConfig::validate() const {
  check(steps >= 0, "train.steps", "must be >= 0");
  check(batch_size > 0, "train.batch_size", "must be positive");
  check(lr > 0 && lr < 1, "train.lr", "must be in (0, 1)");
  check(weight_decay >= 0, "train.weight_decay", "must be >= 0");
  check(beta1 >= 0 && beta1 < 1, "train.beta1", "must be in [0, 1)");
  check(beta2 >= 0 && beta2 < 1, "train.beta2", "must be in [0, 1)");
  check(warmup_steps >= 0, "train.warmup_steps", "must be >= 0");
  check(ema_max_decay >= 0 && ema_max_decay < 1, "train.ema_max_decay", "must be in [0, 1)");
  check(epochs >= 0, "train.epochs", "must be >= 0");
  check(max_steps >= 1, "train.max_steps", "must be >= 1");
}

int TrainConfig::steps_for(int pairs) const {
  if (epochs <= 0) return steps;
  const int64_t n = (static_cast<int64_t>(epochs) * pairs + batch_size - 1) / batch_size;
  return static_cast<int>(std::clamp<int64_t>(n, 1, max_steps));
}

void to_json(nlohmann::json& j, const UnetConfig& c) {
  j = json{{"down_dims", c.down_dims},
           {"kernel_size", c.kernel_size},
           {"n_groups", c.n_groups},
           {"step_embed_dim", c.step_embed_dim}};
}

void from_json(const nlohmann::json& j, UnetConfig& c) {
  require_known_keys(j, {"down_dims", "kernel_size", "n_groups", "step_embed_dim"}, "unet");
  read(j, "down_dims", c.down_dims, "unet");
  read(j, "kernel_size", c.kernel_size, "unet");
  read(j, "n_groups", c.n_groups, "unet");
  read(j, "step_embed_dim", c.step_embed_dim, "unet");
}

void to_json(nlohmann::json& j, const SchedulerConfig& c) {
  j = json{{"num_train_timesteps", c.num_train_timesteps},
           {"num_inference_steps", c.num_inference_steps},
           {"prediction", to_string(c.prediction)},
           {"sampler", to_string(c.sampler)},
           {"clip_sample", c.clip_sample}};
}

void from_json(const nlohmann::json& j, SchedulerConfig& c) {
  require_known_keys(
      j, {"num_train_timesteps", "num_inference_steps", "prediction", "sampler", "clip_sample"},
      "scheduler");
  read(j, "num_train_timesteps", c.num_train_timesteps, "scheduler");
  read(j, "num_inference_steps", c.num_inference_steps, "scheduler");
  std::string s;
  if (j.contains("prediction")) {
    read(j, "prediction", s, "scheduler");
    c.prediction = prediction_from_string(s);
  }
  if (j.contains("sampler")) {
    read(j, "sampler", s, "scheduler");
    c.sampler = sampler_from_string(s);
  }
  read(j, "clip_sample", c.clip_sample, "scheduler");
}

void to_json(nlohmann::json& j, const PolicyConfig& c) {
  j = json{{"obs_dim", c.obs_dim},         {"action_dim", c.action_dim},
           {"horizon", c.horizon},         {"action_steps", c.action_steps},
           {"unet", c.unet},               {"scheduler", c.scheduler},
           {"relative_actions", c.relative_actions}, {"action_norm_per_step", c.action_norm_per_step}};
}

void from_json(const nlohmann::json& j, PolicyConfig& c) {
  require_known_keys(j, {"obs_dim", "action_dim", "horizon", "action_steps", "unet", "scheduler", "relative_actions",
                         "action_norm_per_step"},
                     "policy");
  read(j, "relative_actions", c.relative_actions, "policy");
  read(j, "action_norm_per_step", c.action_norm_per_step, "policy");
  read(j, "obs_dim", c.obs_dim, "policy");
  read(j, "action_dim", c.action_dim, "policy");
  read(j, "horizon", c.horizon, "policy");
  read(j, "action_steps", c.action_steps, "policy");
  if (j.contains("unet")) from_json(j.at("unet"), c.unet);
  if (j.contains("scheduler")) from_json(j.at("scheduler"), c.scheduler);
}

void to_json(nlohmann::json& j, const TrainConfig& c) {
  j = json{{"steps", c.steps},
           {"batch_size", c.batch_size},
           {"lr", c.lr},
           {"weight_decay", c.weight_decay},
           {"beta1", c.beta1},
           {"beta2", c.beta2},
           {"warmup_steps", c.warmup_steps},
           {"grad_clip", c.grad_clip},
           {"ema_power", c.ema_power},
           {"ema_max_decay", c.ema_max_decay},
           {"seed", c.seed},
           {"fit_normalizer", c.fit_normalizer},
           {"from_scratch", c.from_scratch},
           {"epochs", c.epochs},
           {"max_steps", c.max_steps}};
}

void from_json(const nlohmann::json& j, TrainConfig& c) {
  require_known_keys(j,
                     {"steps", "batch_size", "lr", "weight_decay", "beta1", "beta2", "warmup_steps",
                      "grad_clip", "ema_power", "ema_max_decay", "seed", "fit_normalizer", "from_scratch", "epochs", "max_steps"},
                     "train");
  read(j, "steps", c.steps, "train");
  read(j, "batch_size", c.batch_size, "train");
  read(j, "lr", c.lr, "train");
  read(j, "weight_decay", c.weight_decay, "train");
  read(j, "beta1", c.beta1, "train");
  read(j, "beta2", c.beta2, "train");
  read(j, "warmup_steps", c.warmup_steps, "train");
  read(j, "grad_clip", c.grad_clip, "train");
  read(j, "ema_power", c.ema_power, "train");
  read(j, "ema_max_decay", c.ema_max_decay, "train");
  read(j, "seed", c.seed, "train");
  read(j, "fit_normalizer", c.fit_normalizer, "train");
  read(j, "from_scratch", c.from_scratch, "train");
  read(j, "epochs", c.epochs, "train");
  read(j, "max_steps", c.max_steps, "train");
}

PolicyConfig policy_config_from_json(const std::string& text, const std::string& source) {
  PolicyConfig c;
  try {
    from_json(json::parse(text), c);
    c.validate();
  } catch (const json::exception& e) {
    throw Error(source + ": malformed JSON: " + e.what());
  } catch (const Error& e) {
    throw Error(source + ": " + e.what());
  }
  return c;
}

std::vector<std::string> config_differences(const PolicyConfig& a, const PolicyConfig& b) {
  std::vector<std::string> out;
  const json ja = a, jb = b;
  const json patch = json::diff(ja, jb);
  for (const auto& op : patch) {
    const std::string path = op.at("path").get<std::string>();
    // "/unet/down_dims/0" -> "unet.down_dims"; report each field once.
    std::string field = path.substr(1);
    std::replace(field.begin(), field.end(), '/', '.');
    const json::json_pointer ptr(path);
    std::string field_top = field;
    const json::json_pointer parent = ptr.parent_pointer();
    if (!parent.empty() && ja.at(parent).is_array()) {
      field_top = parent.to_string().substr(1);
      std::replace(field_top.begin(), field_top.end(), '/', '.');
      const std::string line =
          field_top + ": " + ja.at(parent).dump() + " vs " + jb.at(parent).dump();
      if (std::find(out.begin(), out.end(), line) == out.end()) out.push_back(line);
      continue;
    }
    const std::string va = ja.contains(ptr) ? ja.at(ptr).dump() : "(none)";
    const std::string vb = jb.contains(ptr) ? jb.at(ptr).dump() : "(none)";
    out.push_back(field + ": " + va + " vs " + vb);
  }
  return out;
}

}  // namespace dd
