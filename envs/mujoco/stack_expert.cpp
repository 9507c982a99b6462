#include "envs/mujoco/stack_expert.h"

#include "core/config.h"

namespace dd::mj {

PickPlaceState StackExpert::read(const ArmEnv& base) const {
  const auto* env = dynamic_cast<const StackEnv*>(&base);
  if (!env) throw Error("stack expert: the env is not a StackEnv");
  const StackConfig& c = env->config();
  PickPlaceState s;
  s.object = env->red_pos();
  s.object_yaw = env->red_yaw();
  s.width = 2 * c.red_half;
  const Eigen::Vector3d g = env->green_pos();
  s.place = {g.x(), g.y(), g.z() + c.green_half + c.red_half + 0.004};
  s.approach = 0.08;
  s.lower_speed = 0.007;
  s.placed = env->red_on_green();
  const double m = c.green_half + 0.035;
  s.obstacles.push_back({{g.x() - m, g.y() - m, -1}, {g.x() + m, g.y() + m, g.z() + c.green_half}});
  s.hang = 2 * c.red_half;
  return s;
}

}  // namespace dd::mj
