// diffdagger train: behaviour cloning on demonstrations (a data set, or collected on the spot), with
// rollouts of the trained policy and a learning curve over training steps.
#include <fmt/format.h>

#include "app/commands.h"
#include "envs/registry.h"
#include "app/experiments.h"
#include "core/task_config.h"

namespace dd::app {

Command add_train(CLI::App& app) {
  auto* cmd = app.add_subcommand("train", "Train a policy on demonstrations (BC), save it, and roll it out");
  struct Opts {
    std::string task = "stack", config, expert;
    TrainOptions train;
    int steps = -1, batch = 0;  // -1: the preset's
    uint64_t seed = 0;
  };
  auto o = std::make_shared<Opts>();
  add_task_option(cmd, o->task, "(its preset; another, e.g. push_2experts, through a --config file naming it)");
  cmd->add_option("--config", o->config, "YAML config file overriding the task's preset");
  cmd->add_option("--data", o->train.data, "data set to train on (robomimic layout); without it, --demos are collected");
  cmd->add_option("--demos", o->train.demos, "the first N successful expert episodes (0: all)")->capture_default_str()->check(CLI::NonNegativeNumber);
  cmd->add_option("--expert", o->expert, "expert mode when collecting (default: the preset's)");
  cmd->add_option("--out", o->train.out, "output folder: policy.pt, curve.csv, losses.csv, summary.json, config.json")->required();
  cmd->add_option("--steps", o->steps, "gradient steps (default: what BC gets in eval, the preset's per-update steps times its updates; 0 with --init: roll out only)")->check(CLI::NonNegativeNumber);
  cmd->add_option("--batch", o->batch, "batch size (default: the preset's)")->check(CLI::NonNegativeNumber);
  cmd->add_option("--eval", o->train.eval_episodes, "rollouts of the trained policy")->capture_default_str()->check(CLI::NonNegativeNumber);
  cmd->add_option("--eval-every", o->train.eval_every, "also roll out every this many steps (a curve over training)")->check(CLI::NonNegativeNumber);
  cmd->add_option("--curve-eval", o->train.curve_episodes, "rollouts at the --eval-every points (default: --eval's)")->check(CLI::NonNegativeNumber);
  cmd->add_option("--init", o->train.init, "checkpoint to start from (with --steps 0: only roll it out)");
  cmd->add_option("--eval-seed", o->train.eval_seed, "seed of the first rollout")->capture_default_str();
  cmd->add_option("--threshold", o->train.threshold,
                  "also set Diff-DAgger's threshold over the training pairs: screened (as eval does) or both (and every pair at all rows, for comparison)")
      ->check(CLI::IsMember({"screened", "both"}));
  cmd->add_option("--save-every", o->train.save_every,
                  "leave a resume point every this many steps (also after each curve point); rerunning a stopped run's command continues it")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--seed", o->seed, "seed of the network, the minibatches and the collected demonstrations")->capture_default_str();
  return [o] {
    ExperimentConfig c = o->config.empty() ? preset(task_info(o->task).preset) : resolve_config("", o->config);
    if (!o->expert.empty()) c.expert = o->expert;
    // By default the budget BC gets in `eval`: the preset's per-update steps times the number of
    // updates a DAgger run makes (or, with from-scratch updates, the epoch rule).
    if (o->steps >= 0) c.train.steps = o->steps, c.train.epochs = 0;
    else if (!c.train.from_scratch) c.train.steps *= bc_budget_factor(c.dagger);
    if (o->batch > 0) c.train.batch_size = o->batch;
    c.train.seed = o->seed;
    c.dagger.seed = o->seed;
    const TrainRunResult r = run_train(c, o->train);
    fmt::print("trained on {} demonstrations ({} pairs) for {} steps in {:.1f} s; final loss {:.4g}", r.demos, r.pairs,
               c.train.steps_for(r.pairs), r.train_s, r.final_loss);
    if (o->train.eval_episodes > 0) fmt::print("; success {:.2f} over {} rollouts", r.success, o->train.eval_episodes);
    fmt::print("\npolicy in {}/policy.pt\n", o->train.out);
    return 0;
  };
}

Command add_curves(CLI::App& app) {
  auto* cmd = app.add_subcommand("curves", "Gather `train` runs (one per subfolder) into learning-curve CSV and PNG files");
  auto dir = std::make_shared<std::string>();
  cmd->add_option("dir", *dir, "folder whose subfolders are train --out folders")->required();
  return [dir] {
    const int n = write_learning_curves(*dir);
    fmt::print("{} run{}: {}/curves.csv, {}/success_vs_demos.png, {}/success_vs_steps.png\n", n, n == 1 ? "" : "s", *dir, *dir, *dir);
    return 0;
  };
}

}  // namespace dd::app
