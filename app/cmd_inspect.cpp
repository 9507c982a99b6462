// diffdagger inspect CHECKPOINT; import-policy / export-policy: diffusion_policy state_dicts in and out.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <iostream>
#include <nlohmann/json.hpp>

#include "app/commands.h"
#include "envs/registry.h"
#include "core/interop.h"
#include "core/policy.h"
#include "core/task_config.h"

namespace dd::app {

Command add_inspect(CLI::App& app) {
  auto* cmd = app.add_subcommand("inspect", "Print a policy checkpoint's config, size and normalisers");
  auto path = std::make_shared<std::string>();
  cmd->add_option("checkpoint", *path, "policy checkpoint (.pt)")->required();
  return [path] {
    spdlog::set_level(spdlog::level::warn);
    const auto policy = DiffusionPolicy::from_checkpoint(*path);
    std::cout << *path << "\n"
              << "parameters: " << policy->num_parameters() << "\n"
              << "config: " << nlohmann::json(policy->config()).dump(2) << "\n";
    auto print = [](const char* name, const Normalizer& n) {
      std::cout << name << " normalizer (x * scale + offset):\n";
      for (int i = 0; i < n.dim(); ++i) std::cout << fmt::format("  [{}] scale {:.6g} offset {:.6g}\n", i, n.scale()[i], n.offset()[i]);
    };
    print("observation", policy->obs_normalizer());
    print("action", policy->action_normalizer());
    return 0;
  };
}

Command add_import_policy(CLI::App& app) {
  auto* cmd = app.add_subcommand("import-policy",
                                 "Turn a Python diffusion_policy ConditionalUnet1D state_dict (and a JSON with its normalizer and "
                                 "settings) into a diffdagger checkpoint that gui --policy and train --init run");
  struct Options {
    std::string state_dict, json, task = "nav2d", out;
  };
  auto o = std::make_shared<Options>();
  cmd->add_option("state_dict", o->state_dict, "torch.save(model.state_dict()) file (a plain dict of tensors)")->required();
  cmd->add_option("--json", o->json, "normalizer and settings: obs/action scale and offset, horizon, n_action_steps, prediction_type, "
                                     "num_train_timesteps, ... (see README)")->required();
  cmd->add_option("--task", o->task, "task the policy acts in (its observation and action sizes are checked)")->capture_default_str();
  cmd->add_option("--out", o->out, "checkpoint to write (.pt)")->required();
  return [o] {
    spdlog::set_level(spdlog::level::warn);
    const ExperimentConfig c = preset(task_info(o->task).preset);
    const auto policy = import_diffusion_policy(o->state_dict, o->json, c.policy);
    policy->save(o->out);
    const PolicyConfig& p = policy->config();
    fmt::print("imported {} parameters: down_dims {}, kernel {}, step embedding {}, T_p {}, T_a {}, {} over {} timesteps ({} sampling "
               "steps)\nwrote {}\n",
               policy->num_parameters(), nlohmann::json(p.unet.down_dims).dump(), p.unet.kernel_size, p.unet.step_embed_dim, p.horizon,
               p.action_steps, to_string(p.scheduler.prediction), p.scheduler.num_train_timesteps, p.scheduler.num_inference_steps,
               o->out);
    return 0;
  };
}

Command add_export_policy(CLI::App& app) {
  auto* cmd = app.add_subcommand("export-policy", "Write a checkpoint as a diffusion_policy ConditionalUnet1D state_dict and its JSON");
  struct Options {
    std::string checkpoint, state_dict, json;
  };
  auto o = std::make_shared<Options>();
  cmd->add_option("checkpoint", o->checkpoint, "policy checkpoint (.pt)")->required();
  cmd->add_option("--state-dict", o->state_dict, "state_dict file to write (torch.load reads it)")->required();
  cmd->add_option("--json", o->json, "normalizer and settings file to write")->required();
  return [o] {
    spdlog::set_level(spdlog::level::warn);
    export_diffusion_policy(*DiffusionPolicy::from_checkpoint(o->checkpoint), o->state_dict, o->json);
    fmt::print("wrote {} and {}\n", o->state_dict, o->json);
    return 0;
  };
}

}  // namespace dd::app
