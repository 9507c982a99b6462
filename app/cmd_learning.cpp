// diffdagger dagger | eval: interactive learning and the paper's evaluation.
#include <fmt/format.h>

#include "app/commands.h"
#include "envs/registry.h"
#include "app/experiments.h"

namespace dd::app {

Command add_dagger(CLI::App& app) {
  auto* cmd = app.add_subcommand("dagger", "One interactive-learning run, headless, with the scripted expert");
  struct Opts {
    std::string task = "nav2d", config, method = "diff", out, expert;
    uint64_t seed = 0;
  };
  auto o = std::make_shared<Opts>();
  add_task_option(cmd, o->task);
  cmd->add_option("--method", o->method, "query rule")->capture_default_str()->check(CLI::IsMember(method_names()));
  cmd->add_option("--out", o->out, "output folder: dataset.hdf5, checkpoints/, queries.jsonl, config.json")->required();
  cmd->add_option("--config", o->config, "YAML config file overriding the task's preset");
  cmd->add_option("--expert", o->expert, "expert mode (nav2d: cw, ccw, mixed; push: those and alternate; push, plug: +noise records demonstrations with execution noise; default: the preset's)");
  cmd->add_option("--seed", o->seed, "random seed")->capture_default_str();
  return [o] {
    ExperimentConfig c = resolve_config(o->task, o->config);
    c.dagger.seed = o->seed;
    DaggerRunOptions ro;
    ro.method = o->method;
    ro.out = o->out;
    if (!o->expert.empty()) c.expert = o->expert;
    const DaggerRunResult r = run_dagger(c, ro);
    fmt::print("{} on {}: {} episodes, {} expert demonstrations ({} interventions: {} queries, {} time-outs), {} updates\n"
               "wall-clock: training {:.1f} s, threshold setting {:.1f} s, inference {:.1f} s\n"
               "data set {}, checkpoints in {}/checkpoints, query log {}/queries.jsonl\n",
               o->method, c.task, r.episodes, r.expert_demos, r.interventions, r.queries, r.timeouts, r.updates, r.train_s,
               r.threshold_s, r.inference_s, r.dataset, o->out, o->out);
    return 0;
  };
}

Command add_eval(CLI::App& app) {
  auto* cmd = app.add_subcommand("eval", "RQ1-RQ3 of the paper for every method on a task, headless");
  struct Opts {
    std::string task = "nav2d", config;
    EvalOptions eval;
    bool quick = false;
  };
  auto o = std::make_shared<Opts>();
  add_task_option(cmd, o->task, "(its preset; --config for another)");
  cmd->add_option("--out", o->eval.out, "output folder")->capture_default_str();
  cmd->add_option("--config", o->config, "YAML config file overriding the task's preset");
  cmd->add_flag("--quick", o->quick, "tiny budgets, for a smoke test (minutes)");
  cmd->add_option("--seeds", o->eval.seeds, "seeds per method")->capture_default_str()->check(CLI::Range(1, 20));
  cmd->add_option("--episodes", o->eval.episodes, "rollouts per measurement")->capture_default_str()->check(CLI::PositiveNumber);
  cmd->add_option("--methods", o->eval.methods, "methods to compare")->delimiter(',')->check(CLI::IsMember(method_names()));
  cmd->add_option("--jobs", o->eval.jobs,
                  "cells (method, seed, RQ1 or RQ2) to run at a time, each in a process of its own with one thread; logs in OUT/logs "
                  "(1: one after another in this process, with --threads)")
      ->capture_default_str()
      ->check(CLI::Range(1, 64));
  auto* only_rq1 = cmd->add_flag("--only-rq1", o->eval.only_rq1, "run only the RQ1 cells (the query rules on the shared policies) and print them; no report");
  cmd->add_flag("--report", o->eval.report_only,
                "run no cell: write the report from the cells finished so far (each row over the seeds it has) and list the "
                "cells still to run; for an evaluation in progress, or one that another machine finishes")
      ->excludes(only_rq1);
  auto* no_cache = cmd->add_flag("--no-train-cache", "train every ensemble update, even one that another cell of this folder "
                                 "trained on the same data from the same weights (by default its members are loaded from "
                                 "OUT/runs/ensemble_cache; the cost reported is the training's when it ran)");
  cmd->add_option("--cell", o->eval.cell,
                  "run only this cell, METHOD:SEED:rq1|rq2 (SEED below --seeds), in OUT or in a new OUT it prepares; what --jobs gives "
                  "each child, and a way to run an evaluation a cell at a time");
  return [o, no_cache] {
    ExperimentConfig c = resolve_config(o->task, o->config);
    EvalOptions e = o->eval;
    e.train_cache = no_cache->count() == 0;
    if (o->quick) e.apply_quick(c);
    run_eval(c, e);
    return 0;
  };
}

Command add_plot(CLI::App& app) {
  auto* cmd = app.add_subcommand("plot", "Figures 4 (wall-clock per iteration) and 5 (who acted when) from a run folder's event logs");
  auto o = std::make_shared<PlotOptions>();
  cmd->add_option("dir", o->dir, "an eval --out folder (its runs/METHOD_seedS) or a dagger --out folder; finished or not")->required();
  cmd->add_option("--seed", o->seed, "which seed's runs, in an eval folder")->capture_default_str()->check(CLI::NonNegativeNumber);
  cmd->add_option("--episode", o->episode, "figure 5's episode (default: N_i + 1, the first the robot acts in)")->check(CLI::NonNegativeNumber);
  return [o] {
    for (const std::string& f : plot_runs(*o)) fmt::print("{}\n", f);
    return 0;
  };
}

}  // namespace dd::app
