// The diffdagger subcommands. Each registers its options on the CLI app and returns the function that
// runs it; main() calls the one that was chosen. A command returns the process exit code.
#pragma once

#include <functional>
#include <string>

#include <CLI/CLI.hpp>

namespace dd::app {

using Command = std::function<int()>;

/// `--task NAME` on a command; its help lists the registered tasks, then `more` when given.
CLI::Option* add_task_option(CLI::App* cmd, std::string& task, const std::string& more = "");

/// `bimodal`: train a small policy on a synthetic two-mode data set, sample it, score it, save it.
Command add_bimodal(CLI::App& app);
/// `demo2d`: the 2-D multimodality demo (figure 2).
Command add_demo2d(CLI::App& app);
/// `dagger`: one interactive-learning run with the scripted expert.
Command add_dagger(CLI::App& app);
/// `eval`: RQ1-RQ3 for every method on a task.
Command add_eval(CLI::App& app);
/// `plot DIR`: figures 4 and 5 from the event logs of an eval or dagger run folder.
Command add_plot(CLI::App& app);
/// `dataset info|export|merge`.
Command add_dataset(CLI::App& app);
/// `gui`: the operator console, in a window or headless.
Command add_gui(CLI::App& app);
/// `render`: a MuJoCo task's cameras as PNG files.
Command add_render(CLI::App& app);
/// `collect`: expert demonstrations into a data set.
Command add_collect(CLI::App& app);
/// `train`: behaviour cloning on demonstrations, with rollouts and a learning curve.
Command add_train(CLI::App& app);
/// `curves DIR`: learning curves from the train runs in DIR.
Command add_curves(CLI::App& app);
/// `inspect`: print a checkpoint's config, parameter count and normalisers.
Command add_inspect(CLI::App& app);
/// `import-policy` / `export-policy`: diffusion_policy state_dicts in and out (core/interop.h).
Command add_import_policy(CLI::App& app);
Command add_export_policy(CLI::App& app);

}  // namespace dd::app
