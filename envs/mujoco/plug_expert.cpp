#include "envs/mujoco/plug_expert.h"

#include "core/config.h"

namespace dd::mj {

bool PlugExpert::gave_up(const Env& base) const {
  const auto* env = dynamic_cast<const PlugEnv*>(&base);
  return env && env->toppled();
}

PickPlaceState PlugExpert::read(const ArmEnv& base) const {
  const auto* env = dynamic_cast<const PlugEnv*>(&base);
  if (!env) throw Error("plug expert: the env is not a PlugEnv");
  PickPlaceState s;
  s.object = env->charger_pos();
  s.object_yaw = env->charger_yaw();
  s.width = 2 * env->config().handle_half;
  const Eigen::Vector3d socket = env->socket_pos();
  s.place = {socket.x(), socket.y(), env->seated_height()};
  s.place_yaw = env->socket_yaw();
  s.align_yaw = true;
  s.plumb_lift = true;  // the dock holds the prong with 1 mm to spare
  s.approach = 0.05;
  s.lower_speed = 0.003;
  s.placed = env->inserted();
  const double m = 0.04 + 0.03;  // receptacle outer half-width and a margin
  s.obstacles.push_back({{socket.x() - m, socket.y() - m, -1}, {socket.x() + m, socket.y() + m, 0.035}});
  const Eigen::Vector3d dock = env->dock_pos();
  const double n = env->dock_outer_half() + 0.03;  // and a margin
  s.obstacles.push_back({{dock.x() - n, dock.y() - n, -1}, {dock.x() + n, dock.y() + n, PlugEnv::kDockWallHeight}});
  s.hang = 0.045;
  return s;
}

}  // namespace dd::mj
