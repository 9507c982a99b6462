// diffdagger gui: the operator console, in a window or headless.
#include <fmt/format.h>

#include "app/commands.h"
#include "envs/registry.h"
#include "app/experiments.h"
#include "ui/console_app.h"

namespace dd::app {

Command add_gui(CLI::App& app) {
  auto* cmd = app.add_subcommand("gui", "The operator console: live loss, threshold and query alerts, takeover");
  struct Opts {
    std::string task = "nav2d", method = "diff", config, expert, out, on_query = "pause";
    std::vector<std::string> policies;
    uint64_t seed = 0;
    bool headless = false, quick = false;
    double speed = 1.0;
    ui::ConsoleRunOptions run;
  };
  auto o = std::make_shared<Opts>();
  add_task_option(cmd, o->task);
  cmd->add_option("--method", o->method, "query rule")->capture_default_str()->check(CLI::IsMember(method_names()));
  cmd->add_option("--config", o->config, "YAML config file overriding the task's preset");
  cmd->add_option("--expert", o->expert, "scripted expert mode (nav2d: cw, ccw, mixed; push: those and alternate; push, plug: +noise records demonstrations with execution noise; default: the preset's)");
  cmd->add_option("--seed", o->seed, "random seed")->capture_default_str();
  cmd->add_option("--out", o->out, "output folder (default: out/gui/TASK_METHOD_N): dataset.hdf5, session.jsonl, checkpoints/");
  cmd->add_option("--on-query", o->on_query, "pause: wait for the operator; expert: the scripted expert answers")
      ->capture_default_str()->check(CLI::IsMember({"pause", "expert"}));
  cmd->add_option("--speed", o->speed, "control steps per second as a multiple of the task's rate")->capture_default_str();
  cmd->add_flag("--quick", o->quick, "small training budgets and schedule (a demo or a test, not an experiment)");
  cmd->add_flag("--headless", o->headless, "no window: render through EGL at a fixed time step");
  cmd->add_option("--screenshots", o->run.screenshots, "folder for query.png, takeover.png, update.png (F12 in a window)");
  cmd->add_option("--policy", o->policies,
                   "checkpoint(s) the first update adopts instead of training (e.g. from import-policy; one per member for "
                   "ensemble and thrifty): the initial demonstrations then only set the threshold");
  cmd->add_option("--script", o->run.script, "headless: YAML list of input events, e.g. - {on: query, after: 8, do: take_over}");
  cmd->add_option("--max-frames", o->run.max_frames, "headless: stop after this many frames (default 20000)");
  cmd->add_option("--width", o->run.width, "window or screenshot width")->capture_default_str();
  cmd->add_option("--height", o->run.height, "window or screenshot height")->capture_default_str();
  return [o] {
    ui::ConsoleOptions c;
    c.config = resolve_config(o->task, o->config);
    c.config.dagger.seed = o->seed;
    if (o->quick) {
      EvalOptions e;
      e.apply_quick(c.config);
    }
    if (!o->policies.empty()) {  // the session starts from these policies: their network, not the preset's
      const size_t want = method_info(o->method).ensemble ? static_cast<size_t>(c.config.method.members) : 1;
      if (o->policies.size() != want)
        throw Error(fmt::format("gui --policy: method {} adopts {} checkpoint{} (one per member for ensemble and thrifty), got {}",
                                o->method, want, want == 1 ? "" : "s", o->policies.size()));
      use_checkpoint_network(c.config, o->policies.front());
      c.policies = o->policies;
    }
    c.method = o->method;
    c.expert_mode = o->expert;
    c.out = o->out;
    c.pause_on_query = o->on_query == "pause";
    c.speed = o->speed;
    if (!o->run.script.empty() && !o->headless) throw Error("gui: --script needs --headless");
    return o->headless ? ui::run_headless(c, o->run) : ui::run_window(c, o->run);
  };
}

}  // namespace dd::app
