#include "envs/registry.h"

#include "core/config.h"
#include "envs/nav2d.h"
#include "envs/nav2d_expert.h"
#include "envs/mujoco/stack.h"
#include "envs/mujoco/stack_expert.h"
#include "envs/mujoco/plug.h"
#include "envs/mujoco/plug_expert.h"
#include "envs/mujoco/push.h"
#include "envs/mujoco/push_expert.h"

namespace dd {
namespace {
// "detour" experts: the planner, first going to a seeded point 1-2 cm beside its pre-grasp and hover
// points, so that the demonstrations show corrections onto them (PickPlaceExpert::detour).
constexpr double kExpertDetour = 0.02;
// "+noise" pushing experts: demonstrations recorded with DART-style execution noise (Expert::execution_noise),
// in joint-position change per step [rad]: an eighth of the largest step (PushEnv::max_joint_step, 0.08).
// Pushing policies drift off the demonstrations' arm poses (stick tilted, arm folded) and the clean
// demonstrations never show the way back.
constexpr float kPushExpertNoise = 0.01f;
// "+noise" plugging experts: the same on the commanded TCP position [m], 2 mm a step: plugging
// policies bring the charger down a few millimetres off (results/bc_curves/plug) and clean
// demonstrations hold it centred all the way.
constexpr float kPlugExpertNoise = 0.002f;
}  // namespace

std::vector<std::string> task_names() { return {"nav2d", "nav2d_random", "stack", "push", "plug"}; }

std::unique_ptr<Env> make_env(const std::string& task) {
  if (task == "nav2d") return std::make_unique<Nav2dEnv>();
  if (task == "nav2d_random") return std::make_unique<Nav2dEnv>(nav2d_random_config());
  if (task == "stack") return std::make_unique<mj::StackEnv>();
  if (task == "plug") return std::make_unique<mj::PlugEnv>();
  if (task == "push") return std::make_unique<mj::PushEnv>();
  throw Error("unknown task '" + task + "' (known: nav2d, nav2d_random, stack, push, plug)");
}

std::unique_ptr<Expert> make_expert(const std::string& task, const std::string& mode) {
  if (mode.size() > 6 && mode.compare(mode.size() - 6, 6, "+noise") == 0 && (task == "push" || task == "plug")) {
    auto expert = make_expert(task, mode.substr(0, mode.size() - 6));
    if (task == "push") {
      expert->execution_noise = Vec::Constant(7, kPushExpertNoise);
    } else {  // the TCP position only: a tilted tool or a twitching gripper would drop the charger
      expert->execution_noise = Vec::Zero(10);
      expert->execution_noise.head(3).setConstant(kPlugExpertNoise);
    }
    return expert;
  }
  if (task == "nav2d" || task == "nav2d_random") {
    if (mode == "cw") return std::make_unique<Nav2dExpert>(Nav2dExpert::Mode::kClockwise);
    if (mode == "ccw") return std::make_unique<Nav2dExpert>(Nav2dExpert::Mode::kCounterClockwise);
    if (mode == "mixed") return std::make_unique<Nav2dExpert>(Nav2dExpert::Mode::kMixed);
    throw Error("nav2d expert: unknown mode '" + mode + "' (known: cw, ccw, mixed)");
  }
  if (task == "stack") {
    if (mode != "mixed" && mode != "planner" && mode != "detour")
      throw Error("stack expert: unknown mode '" + mode + "' (known: planner, detour)");
    auto expert = std::make_unique<mj::StackExpert>();
    if (mode == "detour") expert->detour = kExpertDetour;
    return expert;
  }
  if (task == "push") {
    if (mode == "cw") return std::make_unique<mj::PushExpert>(mj::PushExpert::Mode::kClockwise);
    if (mode == "ccw") return std::make_unique<mj::PushExpert>(mj::PushExpert::Mode::kCounterClockwise);
    if (mode == "mixed") return std::make_unique<mj::PushExpert>(mj::PushExpert::Mode::kMixed);
    if (mode == "alternate") return std::make_unique<mj::PushExpert>(mj::PushExpert::Mode::kAlternate);
    throw Error("push expert: unknown mode '" + mode + "' (known: cw, ccw, mixed, alternate; each with +noise)");
  }
  if (task == "plug") {
    if (mode != "mixed" && mode != "planner" && mode != "detour")
      throw Error("plug expert: unknown mode '" + mode + "' (known: planner, detour; each with +noise)");
    auto expert = std::make_unique<mj::PlugExpert>();
    if (mode == "detour") expert->detour = kExpertDetour;
    return expert;
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
  if (task == "stack")
    return R"({"env_name": "stack", "type": "diffdagger", "env_kwargs": {"hz": 20, "time_limit": 250, "obs": ["q7", "tcp_pos3", "tcp_rot6d", "opening", "red_pos3", "red_quat4", "green_pos3", "green_quat4", "red_minus_tcp3", "green_minus_red3"], "action": ["tcp_pos3", "tcp_rot6d", "grip"]}})";
  if (task == "push")
    return R"({"env_name": "push", "type": "diffdagger", "env_kwargs": {"hz": 20, "time_limit": 650, "goal": [0.52, 0.0, 0.0], "obs": ["q7", "tip_pos3", "tip_rot6d", "block_x", "block_y", "block_cos", "block_sin", "tip_in_block2", "goal_in_block2"], "action": ["dq7"]}})";
  if (task == "plug")
    return R"({"env_name": "plug", "type": "diffdagger", "env_kwargs": {"hz": 20, "time_limit": 500, "clearance_mm": 1, "obs": ["q7", "tcp_pos3", "tcp_rot6d", "opening", "charger_pos3", "charger_quat4", "socket_pos3", "socket_quat4", "charger_minus_tcp3", "socket_minus_charger3"], "action": ["tcp_pos3", "tcp_rot6d", "grip"]}})";
  throw Error("unknown task '" + task + "'");
}

}  // namespace dd
