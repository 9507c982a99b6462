#include "envs/registry.h"

#include <algorithm>

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

namespace {

std::string nav2d_env_args(const std::string& task, const Nav2dConfig& c) {
  const std::string obs = c.observe_obstacle ? R"(["x", "y", "vx", "vy", "obstacle_x", "obstacle_y"])" : R"(["x", "y", "vx", "vy"])";
  return R"({"env_name": ")" + task + R"(", "type": "diffdagger", "env_kwargs": {"hz": )" + std::to_string(c.hz) +
         R"(, "time_limit": )" + std::to_string(c.time_limit) + R"(, "obstacle_jitter": )" + std::to_string(c.obstacle_jitter) +
         R"(, "obs": )" + obs + R"(, "action": ["target_x", "target_y"]}})";
}

std::unique_ptr<Expert> nav2d_expert(const std::string& mode) {
  if (mode == "cw") return std::make_unique<Nav2dExpert>(Nav2dExpert::Mode::kClockwise);
  if (mode == "ccw") return std::make_unique<Nav2dExpert>(Nav2dExpert::Mode::kCounterClockwise);
  return std::make_unique<Nav2dExpert>(Nav2dExpert::Mode::kMixed);
}

template <typename PlannerExpert>
std::unique_ptr<Expert> planner_expert(const std::string& mode) {
  auto expert = std::make_unique<PlannerExpert>();
  if (mode == "detour") expert->detour = kExpertDetour;
  return expert;
}

// the TCP position only: a tilted tool or a twitching gripper would drop the charger
Vec plug_noise() {
  Vec n = Vec::Zero(10);
  n.head(3).setConstant(kPlugExpertNoise);
  return n;
}

std::unique_ptr<Expert> push_expert(const std::string& mode) {
  if (mode == "cw") return std::make_unique<mj::PushExpert>(mj::PushExpert::Mode::kClockwise);
  if (mode == "ccw") return std::make_unique<mj::PushExpert>(mj::PushExpert::Mode::kCounterClockwise);
  if (mode == "alternate") return std::make_unique<mj::PushExpert>(mj::PushExpert::Mode::kAlternate);
  return std::make_unique<mj::PushExpert>(mj::PushExpert::Mode::kMixed);
}

}  // namespace

const std::vector<TaskInfo>& task_registry() {
  static const std::vector<TaskInfo> rows = {
      {"nav2d", "2-D navigation around an obstacle", "nav2d", {"mixed", "cw", "ccw"}, Vec(),
       [] { return std::make_unique<Nav2dEnv>(); }, nav2d_expert, nav2d_env_args("nav2d", Nav2dConfig{})},
      {"nav2d_random", "2-D navigation, the obstacle moved each episode", "nav2d_random", {"mixed", "cw", "ccw"}, Vec(),
       [] { return std::make_unique<Nav2dEnv>(nav2d_random_config()); }, nav2d_expert, nav2d_env_args("nav2d_random", nav2d_random_config())},
      {"stack", "stacking a cube on another", "stack", {"mixed", "planner", "detour"}, Vec(),
       [] { return std::make_unique<mj::StackEnv>(); }, planner_expert<mj::StackExpert>,
       R"({"env_name": "stack", "type": "diffdagger", "env_kwargs": {"hz": 20, "time_limit": 250, "obs": ["q7", "tcp_pos3", "tcp_rot6d", "opening", "red_pos3", "red_quat4", "green_pos3", "green_quat4", "red_minus_tcp3", "green_minus_red3"], "action": ["tcp_pos3", "tcp_rot6d", "grip"]}})"},
      {"push", "pushing a T", "push_2experts", {"mixed", "cw", "ccw", "alternate"}, Vec::Constant(7, kPushExpertNoise),
       [] { return std::make_unique<mj::PushEnv>(); }, push_expert,
       R"({"env_name": "push", "type": "diffdagger", "env_kwargs": {"hz": 20, "time_limit": 650, "goal": [0.52, 0.0, 0.0], "obs": ["q7", "tip_pos3", "tip_rot6d", "block_x", "block_y", "block_cos", "block_sin", "tip_in_block2", "goal_in_block2"], "action": ["dq7"]}})"},
      {"plug", "plugging a charger into a socket", "plug", {"mixed", "planner", "detour"}, plug_noise(),
       [] { return std::make_unique<mj::PlugEnv>(); }, planner_expert<mj::PlugExpert>,
       R"({"env_name": "plug", "type": "diffdagger", "env_kwargs": {"hz": 20, "time_limit": 500, "clearance_mm": 1, "obs": ["q7", "tcp_pos3", "tcp_rot6d", "opening", "charger_pos3", "charger_quat4", "socket_pos3", "socket_quat4", "charger_minus_tcp3", "socket_minus_charger3"], "action": ["tcp_pos3", "tcp_rot6d", "grip"]}})"},
  };
  return rows;
}

const TaskInfo& task_info(const std::string& task) { return find_named(task_registry(), task, "task"); }

std::vector<std::string> task_names() {
  std::vector<std::string> names;
  for (const TaskInfo& t : task_registry()) names.push_back(t.name);
  return names;
}

std::unique_ptr<Env> make_env(const std::string& task) { return task_info(task).make_env(); }

std::unique_ptr<Expert> make_expert(const std::string& task, const std::string& mode) {
  const TaskInfo& t = task_info(task);
  const bool noisy = mode.size() > 6 && mode.compare(mode.size() - 6, 6, "+noise") == 0;
  const std::string base = noisy ? mode.substr(0, mode.size() - 6) : mode;
  std::string known;
  for (const std::string& m : t.expert_modes) known += (known.empty() ? "" : ", ") + m;
  const bool has_noise = t.expert_noise.size() > 0;
  if ((noisy && !has_noise) || std::find(t.expert_modes.begin(), t.expert_modes.end(), base) == t.expert_modes.end())
    throw Error(task + " expert: unknown mode '" + mode + "' (known: " + known + (has_noise ? "; each with +noise)" : ")"));
  auto expert = t.make_expert(base);
  if (noisy) expert->execution_noise = t.expert_noise;
  return expert;
}

std::string env_args(const std::string& task) { return task_info(task).env_args; }

}  // namespace dd
