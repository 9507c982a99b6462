#include "envs/registry.h"

#include "core/config.h"
#include "envs/nav2d.h"
#include "envs/nav2d_expert.h"

namespace dd {

std::vector<std::string> task_names() { return {"nav2d", "nav2d_random"}; }

std::unique_ptr<Env> make_env(const std::string& task) {
  if (task == "nav2d") return std::make_unique<Nav2dEnv>();
  if (task == "nav2d_random") return std::make_unique<Nav2dEnv>(nav2d_random_config());
  throw Error("unknown task '" + task + "' (known: nav2d, nav2d_random; the MuJoCo tasks stack, push and plug are not built yet)");
}

std::unique_ptr<Expert> make_expert(const std::string& task, const std::string& mode) {
  if (task == "nav2d" || task == "nav2d_random") {
    if (mode == "cw") return std::make_unique<Nav2dExpert>(Nav2dExpert::Mode::kClockwise);
    if (mode == "ccw") return std::make_unique<Nav2dExpert>(Nav2dExpert::Mode::kCounterClockwise);
    if (mode == "mixed") return std::make_unique<Nav2dExpert>(Nav2dExpert::Mode::kMixed);
    throw Error("nav2d expert: unknown mode '" + mode + "' (known: cw, ccw, mixed)");
  }
  throw Error("unknown task '" + task + "' for an expert");
}

std::string env_args(const std::string& task) {
  if (task == "nav2d" || task == "nav2d_random") {
    const Nav2dConfig c = task == "nav2d" ? Nav2dConfig{} : nav2d_random_config();
    const std::string obs = c.observe_obstacle ? R"(["x", "y", "vx", "vy", "obstacle_x", "obstacle_y"])" : R"(["x", "y", "vx", "vy"])";
    return R"({"env_name": ")" + task + R"(", "type": "diffdagger", "env_kwargs": {"hz": )" + std::to_string(c.hz) +
           R"(, "time_limit": )" + std::to_string(c.time_limit) + R"(, "obstacle_jitter": )" + std::to_string(c.obstacle_jitter) +
           R"(, "obs": )" + obs + R"(, "action": ["target_x", "target_y"]}})";
  }
  throw Error("unknown task '" + task + "'");
}

}  // namespace dd
