// Experiment configuration per task: the policy, its training budget, the DAgger schedule and the
// query rule, with the paper's Table III values as named presets.
//
// Files are YAML (or JSON) with the sections policy, train, dagger and method; each overrides the
// preset named by `preset`. Unknown keys and out-of-range values are errors naming the file and key.
//
//   preset: push_2experts
//   train: {steps: 3000}
//   dagger: {final_demos: 60}
#pragma once

#include <string>
#include <vector>

#include "core/config.h"
#include "core/method.h"
#include "core/session.h"

namespace dd {

struct ExperimentConfig {
  std::string preset;   // the preset this was built from
  std::string task;     // env name: nav2d, stack, push, plug
  std::string expert = "mixed";  // the expert's mode everywhere the experiment needs one (demonstrations,
                                 // interventions, RQ1): nav2d, push: cw | ccw | mixed | alternate;
                                 // stack, plug: planner
  PolicyConfig policy;
  TrainConfig train;
  DaggerConfig dagger;
  MethodConfig method;
  int rq1_demos = 5;    // N_D: demonstrations for the failure-prediction study (about 50% success)

  void validate() const;
};

/// Preset names: nav2d, nav2d_random, stack, push_1expert, push_2experts, plug.
std::vector<std::string> preset_names();
/// The preset; throws Error naming it when unknown.
ExperimentConfig preset(const std::string& name);
/// How a config departs from the paper's protocol for its task, one plain sentence each: the
/// Table III schedule values that differ (T_p, T_a, T_d, N_i, N_f, N_d, alpha, K, T_L), the network
/// size, the training budget against the authors' code, the observations and the experts. For the
/// 2-D toys, which the paper has no schedule for, one sentence saying so.
std::vector<std::string> paper_deviations(const ExperimentConfig& c);
/// A preset with a file's overrides applied; errors name `path` and the key.
ExperimentConfig load_experiment_config(const std::string& path);
/// The config as JSON text (what runs write next to their results).
std::string to_json_text(const ExperimentConfig& c);

}  // namespace dd
