// Policy and training configuration: plain structs with their defaults in one place.
//
// Every struct converts to and from JSON. Reading rejects unknown keys and out-of-range values
// with a ConfigError that names the key, so a typo is an error and never a silent default.
#pragma once

#include <array>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

namespace dd {

/// An expected failure caused by bad input (a file, a config, a checkpoint); the message names it.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The row of a registry (rows with a `name`) called `name`; throws Error "unknown WHAT 'NAME' (known:
/// a, b, ...)" when there is none. Tasks (envs/registry.h) and methods (core/method.h) are found so.
template <typename Row>
const Row& find_named(const std::vector<Row>& rows, const std::string& name, const std::string& what) {
  std::string known;
  for (const Row& r : rows) {
    if (r.name == name) return r;
    known += (known.empty() ? "" : ", ") + r.name;
  }
  throw Error("unknown " + what + " '" + name + "' (known: " + known + ")");
}

/// What the network is trained to predict.
enum class PredictionType { kEpsilon, kSample, kVelocity };

/// How actions are generated from noise.
enum class SamplerType { kDdpm, kDdim };

/// Shape of the 1-D temporal U-Net (ConditionalUnet1D with FiLM).
struct UnetConfig {
  std::vector<int> down_dims{32, 64, 128};  // channels per level; horizon must divide by 2^(levels-1)
  int kernel_size = 5;                      // temporal convolution kernel (odd)
  int n_groups = 8;                         // GroupNorm groups; must divide every channel count
  int step_embed_dim = 64;                  // sinusoidal diffusion-step embedding width
};

/// The noise schedule and sampler.
struct SchedulerConfig {
  int num_train_timesteps = 16;                        // T_d
  int num_inference_steps = 16;                        // denoising steps when sampling (<= T_d)
  PredictionType prediction = PredictionType::kVelocity;
  SamplerType sampler = SamplerType::kDdpm;
  bool clip_sample = true;                             // clip predicted x0 to [-1, 1]
};

/// Everything that defines a policy's network and data shapes; stored in every checkpoint.
struct PolicyConfig {
  int obs_dim = 4;         // observation features per step (T_o = 1)
  int action_dim = 2;      // action features per step
  int horizon = 16;        // T_p: actions per generated chunk
  int action_steps = 8;    // T_a: actions executed per chunk
  UnetConfig unet;
  SchedulerConfig scheduler;
  /// Action features the network sees relative to a feature of the chunk's own observation: pairs
  /// (action index, observation index). The model learns action[a] - obs[o] at every step of the
  /// chunk, and generated chunks get obs[o] added back (e.g. TCP targets relative to the TCP position
  /// observed when the chunk was planned). Empty: absolute actions.
  std::vector<std::array<int, 2>> relative_actions;
  /// Normalise every (chunk step, action feature) on its own range instead of each action feature
  /// over all steps: the first steps of a relative chunk span centimetres where the last span the
  /// workspace, so they get a finer resolution.
  bool action_norm_per_step = false;
  /// Values in the action normaliser: action_dim, or horizon * action_dim with action_norm_per_step.
  int action_norm_dim() const { return action_norm_per_step ? horizon * action_dim : action_dim; }

  /// Throws Error naming the field if the shapes are inconsistent.
  void validate() const;
};

/// Optimisation settings (AdamW with cosine schedule and warm-up, EMA for sampling).
struct TrainConfig {
  int steps = 2000;             // gradient steps per training call
  int batch_size = 256;         // pairs per step
  double lr = 3e-4;             // peak learning rate
  double weight_decay = 0.01;   // AdamW decoupled weight decay
  double beta1 = 0.9;           // AdamW first-moment decay
  double beta2 = 0.99;          // AdamW second-moment decay
  int warmup_steps = 100;       // linear warm-up before the cosine decay
  double grad_clip = 1.0;       // max global gradient norm (<= 0 disables)
  double ema_power = 0.75;      // EMA warm-up power: decay = 1 - (1 + step)^-power
  double ema_max_decay = 0.9999;
  uint64_t seed = 0;            // minibatch order, noise and timesteps
  bool fit_normalizer = true;   // refit the normalizer on the training data before training
  // How a policy update trains. false (the default): continue from the current weights for `steps`
  // gradient steps. true: re-initialise the network and train from scratch (the paper's text and the
  // authors' released code); the number of steps then comes from `epochs` when it is positive.
  bool from_scratch = false;
  int epochs = 0;               // > 0: steps = min(max_steps, ceil(epochs * pairs / batch_size))
  int max_steps = 30000;        // cap of the epoch rule

  void validate() const;
  /// The gradient steps for a data set of `pairs` pairs (steps, or the epoch rule when epochs > 0).
  int steps_for(int pairs) const;
};

/// Named presets: "cpu" (default, fast on 2 cores), "medium" (64,128,256) and "paper" (256,512,1024).
UnetConfig unet_preset(const std::string& name);

std::string to_string(PredictionType p);
std::string to_string(SamplerType s);

void to_json(nlohmann::json& j, const UnetConfig& c);
void from_json(const nlohmann::json& j, UnetConfig& c);
void to_json(nlohmann::json& j, const SchedulerConfig& c);
void from_json(const nlohmann::json& j, SchedulerConfig& c);
void to_json(nlohmann::json& j, const PolicyConfig& c);
void from_json(const nlohmann::json& j, PolicyConfig& c);
void to_json(nlohmann::json& j, const TrainConfig& c);
void from_json(const nlohmann::json& j, TrainConfig& c);

/// Parses a PolicyConfig from JSON text; errors name `source` (a file name) and the key.
PolicyConfig policy_config_from_json(const std::string& text, const std::string& source);

/// Lists the fields in which two configs differ, as "field: a vs b" lines (empty if equal).
std::vector<std::string> config_differences(const PolicyConfig& a, const PolicyConfig& b);

}  // namespace dd
