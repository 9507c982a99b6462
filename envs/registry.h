// Tasks and experts by name. Registration is explicit (a static library would drop self-registering
// statics): add a line to make_env / make_expert for a new task.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/env.h"

namespace dd {

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
