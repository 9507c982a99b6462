// diffdagger demo2d --out DIR [--quick] [--full]
#include "app/commands.h"
#include "app/demo2d.h"

namespace dd::app {

Command add_demo2d(CLI::App& app) {
  auto* cmd = app.add_subcommand("demo2d", "The 2-D multimodality demo (the paper's figure 2), headless");
  auto o = std::make_shared<Demo2dOptions>();
  auto quick = std::make_shared<bool>(false), full = std::make_shared<bool>(false);
  cmd->add_option("--out", o->out, "output folder")->capture_default_str();
  cmd->add_flag("--quick", *quick, "a reduced run (about a minute), for tests");
  cmd->add_flag("--full", *full, "the full run: 3 seeds, each in OUT/seed_S, and a summary over them in OUT");
  cmd->add_option("--seed", o->seed, "random seed (the first, with --full or --seeds)")->capture_default_str();
  cmd->add_option("--seeds", o->seeds, "seeds to run (--full: 3)")->capture_default_str()->check(CLI::Range(1, 20));
  cmd->add_option("--preset", o->preset, "network size: tiny, cpu, medium, paper")->capture_default_str();
  cmd->add_option("--prediction", o->prediction, "diffusion objective: v_prediction, epsilon, sample")
      ->capture_default_str()
      ->check(CLI::IsMember({"v_prediction", "epsilon", "sample"}));
  cmd->add_option("--demos", o->demos, "expert demonstrations")->capture_default_str()->check(CLI::PositiveNumber);
  cmd->add_option("--steps", o->train_steps, "training steps per policy")->capture_default_str()->check(CLI::PositiveNumber);
  cmd->add_option("--members", o->members, "ensemble size")->capture_default_str()->check(CLI::Range(2, 20));
  cmd->add_option("--runs", o->runs, "probe states per region")->capture_default_str()->check(CLI::PositiveNumber);
  cmd->add_option("--grid", o->grid, "field cells per side")->capture_default_str()->check(CLI::Range(4, 200));
  return [o, quick, full] {
    Demo2dOptions opts = *o;
    if (*full) opts.seeds = std::max(opts.seeds, 3);
    if (*quick) {
      const std::string out = opts.out;
      opts.apply_quick();
      opts.out = out;
    }
    run_demo2d_seeds(opts);
    return 0;
  };
}

}  // namespace dd::app
