// diffdagger: robot-gated interactive imitation learning with diffusion policies.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <map>

#include "app/commands.h"
#include "app/experiments.h"
#include "core/config.h"
#include "core/runtime.h"
#include "envs/registry.h"

namespace dd::app {

CLI::Option* add_task_option(CLI::App* cmd, std::string& task, const std::string& more) {
  return cmd->add_option("--task", task, fmt::format("task: {}{}", fmt::join(task_names(), ", "), more.empty() ? "" : " " + more))
      ->capture_default_str();
}

}  // namespace dd::app

int main(int argc, char** argv) {
  CLI::App app{"diffdagger: teach a robot by correcting it (Diff-DAgger and its baselines)"};
  app.require_subcommand(1);
  int threads = 0;
  bool verbose = false;
  bool one_process = false;
  app.add_option("--threads", threads, "libtorch threads (default: $DD_THREADS or 2)");
  app.add_flag("--one-process", one_process,
               "with 2 threads or more, run training steps, threshold passes and rollouts in this process's threads "
               "instead of splitting them between two one-thread child processes (also $DD_ONE_PROCESS=1)");
  app.add_flag("-v,--verbose", verbose, "debug logging");

  std::map<CLI::App*, dd::app::Command> commands;
  auto add = [&](auto fn) {
    const size_t before = app.get_subcommands({}).size();
    dd::app::Command c = fn(app);
    commands[app.get_subcommands({})[before]] = std::move(c);
  };
  add(dd::app::add_demo2d);
  add(dd::app::add_dagger);
  add(dd::app::add_gui);
  add(dd::app::add_render);
  add(dd::app::add_collect);
  add(dd::app::add_eval);
  add(dd::app::add_train);
  add(dd::app::add_curves);
  add(dd::app::add_plot);
  add(dd::app::add_dataset);
  add(dd::app::add_bimodal);
  add(dd::app::add_inspect);
  add(dd::app::add_import_policy);
  add(dd::app::add_export_policy);

  dd::app::set_command_line(argc, argv);
  CLI11_PARSE(app, argc, argv);
  spdlog::set_level(verbose ? spdlog::level::debug : spdlog::level::info);
  spdlog::set_pattern("%^[%L]%$ %v");
  dd::set_num_threads(threads);
  dd::set_data_parallel_from(one_process);
  try {
    for (auto& [sub, run] : commands)
      if (sub->parsed()) return run();
  } catch (const dd::Error& e) {
    spdlog::error("{}", e.what());
    return 1;
  } catch (const std::exception& e) {  // a library's (a file system error, for instance)
    spdlog::error("{}", e.what());
    return 1;
  }
  return 2;
}
