// diffdagger collect: expert demonstrations into a data set (robomimic layout), with the expert's
// success rate and mean task duration (the paper's Table II columns).
#include <fmt/format.h>

#include <filesystem>

#include "app/commands.h"
#include "core/config.h"
#include "core/dataset.h"
#include "core/evaluation.h"
#include "core/progress.h"
#include "envs/registry.h"

namespace dd::app {

Command add_collect(CLI::App& app) {
  auto* cmd = app.add_subcommand("collect", "Record expert demonstrations into an HDF5 data set");
  struct Opts {
    std::string task = "stack", out, expert = "mixed";
    int episodes = 10;
    uint64_t seed = 0;
    bool keep_failures = false;
  };
  auto o = std::make_shared<Opts>();
  add_task_option(cmd, o->task);
  cmd->add_option("--episodes", o->episodes, "episodes to run")->capture_default_str()->check(CLI::PositiveNumber);
  cmd->add_option("--out", o->out, "data set file (.hdf5); appended to when it exists and matches the task")->required();
  cmd->add_option("--expert", o->expert, "expert mode (nav2d: cw, ccw, mixed; push: those and alternate; stack, plug: planner, detour; push, plug: any of them with +noise, demonstrations recorded with execution noise)")->capture_default_str();
  cmd->add_option("--seed", o->seed, "first episode seed")->capture_default_str();
  cmd->add_flag("--keep-failures", o->keep_failures, "also record episodes the expert failed (marked success = false)");
  return [o] {
    auto env = make_env(o->task);
    auto expert = make_expert(o->task, o->expert);
    const auto parent = std::filesystem::path(o->out).parent_path();
    if (!parent.empty()) std::filesystem::create_directories(parent);
    DatasetWriter writer(o->out, env_args(o->task));
    int ok = 0, recorded = 0;
    double success_steps = 0;
    ProgressBar bar(fmt::format("collect {} ({})", o->task, expert->label()), "success");
    for (int e = 0; e < o->episodes; ++e) {
      const uint64_t seed = o->seed + static_cast<uint64_t>(e);
      const RecordedEpisode rec = expert_episode(*env, *expert, seed);
      ok += rec.success;
      if (rec.success) success_steps += rec.steps();
      if (rec.success || o->keep_failures) {
        writer.append(rec);  // durable before the next episode
        ++recorded;
      }
      bar.update(e + 1, o->episodes, double(ok) / (e + 1));
    }
    bar.finish();
    fmt::print("{} expert on {}: success {}/{} ({:.0f}%), mean duration of successful episodes {:.1f} steps ({:.1f} s); "
               "{} episodes recorded in {}\n",
               expert->label(), o->task, ok, o->episodes, 100.0 * ok / o->episodes, ok ? success_steps / ok : 0.0,
               ok ? success_steps / ok / env->control_hz() : 0.0, recorded, o->out);
    return 0;
  };
}

}  // namespace dd::app
