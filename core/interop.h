// Policies trained in Python's diffusion_policy, in and out.
//
// diffusion_policy's ConditionalUnet1D (with cond_predict_scale, no local conditioning) is the network
// diffdagger trains: the same levels, residual blocks, FiLM (scale then bias), sinusoidal step
// embedding and skip connections, under other parameter names. A state_dict saved from Python as a
// plain dict (`torch.save(policy.model.state_dict(), path)`, or the whole policy's state_dict with its
// `model.` prefix and normalizer) imports by name; the network's shape is read from the weights.
//
// What the weights do not say comes from a JSON file beside them, in diffusion_policy's own terms:
//   {
//     "obs":    {"scale": [...], "offset": [...]},     LinearNormalizer params: y = x * scale + offset
//     "action": {"scale": [...], "offset": [...]},
//     "horizon": 16,                                   T_p (required)
//     "n_action_steps": 8,                             T_a (default: the task's)
//     "n_obs_steps": 1,                                must be 1: diffdagger conditions on one observation
//     "prediction_type": "epsilon",                    epsilon | sample | v_prediction (default epsilon)
//     "num_train_timesteps": 100, "num_inference_steps": 100,   (defaults 100 and num_train_timesteps)
//     "n_groups": 8, "clip_sample": true,              (defaults)
//     "beta_schedule": "squaredcos_cap_v2"             the only schedule diffdagger has
//   }
// The normalizer may instead come from the state_dict (a policy's `normalizer.params_dict.*`); the
// JSON's wins when both are present.
#pragma once

#include <memory>
#include <string>

#include "core/config.h"

namespace dd {

class DiffusionPolicy;

/// Reads a diffusion_policy state_dict and its JSON into a policy for a task whose observations and
/// actions have `obs_dim` and `action_dim` features per step; `defaults` supplies T_a when the JSON has
/// no n_action_steps. Throws Error naming the file and the key or field that is missing, unexpected,
/// malformed or of the wrong shape.
std::unique_ptr<DiffusionPolicy> import_diffusion_policy(const std::string& state_dict_path, const std::string& json_path,
                                                         const PolicyConfig& defaults);

/// The other way: writes `policy`'s sampling (EMA) weights as a diffusion_policy ConditionalUnet1D
/// state_dict (a plain dict of tensors that Python's torch.load reads) and its normalizer and settings
/// as the JSON above. Throws Error for a policy diffusion_policy cannot express (relative actions, or
/// a per-step action normalizer) or when a file cannot be written.
void export_diffusion_policy(const DiffusionPolicy& policy, const std::string& state_dict_path, const std::string& json_path);

}  // namespace dd
