// Tasks by name: one registry row per task (its environment, its scripted experts, the data set's
// description of it, its default preset), used by the command line, the console and the reports.
// Registration is explicit (a static library would drop self-registering statics): a new task is one
// row in envs/registry.cpp. Its teleoperation comes with its Env (Env::teleoperation).
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "core/env.h"

namespace dd {

struct TaskInfo {
  std::string name;                      // "push"
  std::string title;                     // "pushing a T"
  std::string preset;                    // the preset `--task NAME` runs with (core/task_config.h)
  std::vector<std::string> expert_modes; // the scripted expert's modes; "mixed" is every task's default
  Vec expert_noise;                      // "+noise" modes: DART-style execution noise per action component (empty: none)
  std::function<std::unique_ptr<Env>()> make_env;
  std::function<std::unique_ptr<Expert>(const std::string& mode)> make_expert;  // a mode of expert_modes
  std::string env_args;                  // the data set's description of the task (robomimic's env_args, JSON)
};
const std::vector<TaskInfo>& task_registry();
/// The row of `task`; throws Error naming it and listing the known tasks.
const TaskInfo& task_info(const std::string& task);

/// The task names make_env knows.
std::vector<std::string> task_names();
/// A new environment for `task`; throws Error naming the task when unknown.
std::unique_ptr<Env> make_env(const std::string& task);
/// The scripted expert for `task`; `mode` picks a variant where the task has several
/// (nav2d: cw, ccw, mixed; push: cw, ccw, mixed, alternate; stack and plug: planner, detour).
/// Throws Error naming the task or mode when unknown.
std::unique_ptr<Expert> make_expert(const std::string& task, const std::string& mode = "mixed");
/// A JSON description of the task (robomimic's env_args).
std::string env_args(const std::string& task);

}  // namespace dd
