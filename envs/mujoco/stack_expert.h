// The stacking expert: the pick-and-place expert with the red cube as the object and the top of the
// green cube as the place, planning around the green cube.
#pragma once

#include "envs/mujoco/pick_place_expert.h"
#include "envs/mujoco/stack.h"

namespace dd::mj {

class StackExpert : public PickPlaceExpert {
 public:
  std::string name() const override { return detour > 0 ? "stack_detour" : "stack_planner"; }

 protected:
  PickPlaceState read(const ArmEnv& env) const override;
};

}  // namespace dd::mj
