// The 2-D navigation toy of the paper's figure 2, on Box2D.
//
// A round agent in a walled square arena goes from a start region on the left to a goal on the right
// around a round obstacle in the middle, clockwise (over the top) or counter-clockwise (underneath).
//   observation (4): agent x, y [m], vx, vy [m/s]  (+ obstacle centre x, y [m] when observed)
//   action      (2): target position x, y [m]; a proportional controller turns it into a velocity
// An episode ends at the goal (success) or at the time limit.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/env.h"

class b2World;
class b2Body;

namespace dd {

using Vec2 = Eigen::Vector2d;

/// Geometry and dynamics of the toy; defaults in one place.
struct Nav2dConfig {
  double arena_half = 1.2;         // walls at +-arena_half [m]
  double obstacle_radius = 0.4;    // obstacle centred at the origin [m]
  double agent_radius = 0.05;      // [m]
  Vec2 start_center{-0.9, 0.0};    // centre of the start square [m]
  double start_half = 0.08;        // half-width of the start square [m]
  Vec2 goal{0.9, 0.0};             // goal centre [m]
  double goal_radius = 0.08;       // success within this distance [m]
  double gain = 5.0;               // controller: v = gain * (target - position) [1/s]
  double max_speed = 1.0;          // [m/s]
  double hz = 20.0;                // control rate
  int substeps = 4;                // physics steps per control step
  int time_limit = 200;            // T_L [steps]
  double obstacle_jitter = 0.0;    // the obstacle centre is drawn per episode from +-jitter in x and y [m]
  bool observe_obstacle = false;   // append the obstacle centre to the observation (6 values instead of 4)
};

/// The randomised variant used for interactive learning: the obstacle moves up to 0.2 m per episode
/// and its centre is part of the observation, so a policy must generalise from its demonstrations.
Nav2dConfig nav2d_random_config();

class Nav2dEnv : public Env {
 public:
  explicit Nav2dEnv(Nav2dConfig config = {});
  ~Nav2dEnv() override;

  std::string name() const override { return config_.observe_obstacle ? "nav2d_random" : "nav2d"; }
  int obs_dim() const override { return config_.observe_obstacle ? 6 : 4; }
  int action_dim() const override { return 2; }
  int time_limit() const override { return limit_; }
  void set_time_limit(int steps) override { limit_ = steps; }
  double control_hz() const override { return config_.hz; }

  void reset(uint64_t seed) override;
  Vec observation() const override;
  StepResult step(const Vec& action) override;
  bool success() const override { return success_; }
  int steps() const override { return steps_; }
  std::vector<double> save_state() const override;
  void restore_state(const std::vector<double>& state) override;
  /// The operator commands a target position: the dragged point, or a step along the jog direction.
  std::unique_ptr<Teleoperation> teleoperation() const override;
  /// The arena, start square, goal, this episode's obstacle and the agent; actions and observations
  /// start with plane positions.
  std::optional<PlaneScene> plane() const override;
  std::vector<Eigen::Vector3d> action_points(const Mat& chunk) const override;
  std::optional<Eigen::Vector3d> observed_point(const Vec& obs) const override;
  std::optional<Vec> observation_at_rest(const Eigen::Vector2d& p) const override;

  const Nav2dConfig& config() const { return config_; }
  Vec2 position() const;
  Vec2 velocity() const;
  /// Places the agent at an arbitrary state (for probing a policy at chosen points).
  void set_agent(const Vec2& position, const Vec2& velocity);
  /// True if a disc of the agent's radius at `p` overlaps neither the obstacle nor the walls.
  bool is_free(const Vec2& p) const;
  /// The obstacle centre of this episode.
  const Vec2& obstacle_center() const { return obstacle_center_; }

 private:
  Vec observe(const Vec2& p, const Vec2& v) const;  // the observation's layout, in one place

  Nav2dConfig config_;
  std::unique_ptr<b2World> world_;
  b2Body* agent_ = nullptr;
  Vec2 obstacle_center_{0, 0};
  int steps_ = 0;
  int limit_ = 0;
  bool success_ = false;
  bool failed_ = false;
};

/// Which region of figure 2a a position lies in.
enum class Nav2dRegion { kUniModal, kMultiModal, kOutOfDistribution, kNone };

/// "id_um", "id_mm", "ood", "none".
std::string region_name(Nav2dRegion r);

/// Region labels from the expert's two reference paths (rolled out from the centre of the start).
///   multi-modal: within mm_radius of the start centre, where the paths diverge
///   uni-modal: within um_radius of either path (and not multi-modal)
///   out-of-distribution: in free space farther than ood_distance from both paths and the start
class Nav2dRegions {
 public:
  explicit Nav2dRegions(const Nav2dConfig& config = {});

  Nav2dRegion label(const Vec2& p) const;
  /// Distance from p to the nearer reference path.
  double path_distance(const Vec2& p) const;
  const std::vector<Vec2>& path(int mode) const { return mode == 0 ? cw_ : ccw_; }
  const Vec2& divergence_point() const { return config_.start_center; }

  double mm_radius = 0.12;
  double um_radius = 0.06;
  double ood_distance = 0.3;

 private:
  Nav2dConfig config_;
  std::vector<Vec2> cw_, ccw_;
  Nav2dEnv probe_;
};

}  // namespace dd
