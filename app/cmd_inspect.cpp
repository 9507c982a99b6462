// diffdagger inspect CHECKPOINT
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <iostream>
#include <nlohmann/json.hpp>

#include "app/commands.h"
#include "core/policy.h"

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

}  // namespace dd::app
