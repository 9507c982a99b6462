// The plugging expert: the pick-and-place expert with the charger's handle as the object, turning it
// to the socket's yaw on the way and lowering it slowly into the socket.
#pragma once

#include "envs/mujoco/pick_place_expert.h"
#include "envs/mujoco/plug.h"

namespace dd::mj {

class PlugExpert : public PickPlaceExpert {
 public:
  std::string name() const override { return "plug_planner"; }

 protected:
  PickPlaceState read(const ArmEnv& env) const override;
};

}  // namespace dd::mj
