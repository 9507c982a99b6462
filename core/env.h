// The task interface every environment implements (envs/), and the expert interface that drives one.
// Defined in core so that the DAgger session can drive any task; free of physics and GL.
//
// An Env is seeded and deterministic: reset(seed) followed by the same actions gives the same
// trajectory. A step with a non-finite action, or a simulation that goes unstable, ends the episode
// as failed with a warning; it never throws or crashes.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "core/config.h"  // Error
#include "core/types.h"

namespace dd {

/// What one step did.
struct StepResult {
  bool done = false;     // the episode is over (success, failure, or time limit)
  bool success = false;  // the task is achieved
  bool failed = false;   // ended abnormally (non-finite action, unstable simulation)
  std::string warning;   // why it failed, when it did
};

class Env;

/// What an operator gives at one step, whatever the device (keys, mouse, gamepad): the console fills
/// it in, and the task's Teleoperation turns it into an action.
struct OperatorInput {
  Eigen::Vector2d jog{0, 0};      // drive direction in the view's ground plane, each in [-1, 1]
  double lift = 0;                // raise (+1) or lower (-1), where the task has a height
  bool has_target = false;        // a point dragged on the ground plane (world x, y)
  Eigen::Vector2d target{0, 0};
  Eigen::Vector2d forward{1, 0};  // the view's forward direction on the ground (world x, y, unit)
};

/// How an operator drives one task: operator input in, the task's action out. Each task contributes
/// its own (Env::teleoperation), so that a console knows no task's internals.
class Teleoperation {
 public:
  virtual ~Teleoperation() = default;
  /// A takeover starts: the next action starts from the env's state as it is then.
  virtual void begin() = 0;
  virtual Vec action(const Env& env, const OperatorInput& input) = 0;
  /// Closes an open gripper, opens a closed one (tasks without one ignore it).
  virtual void toggle_grip() {}
  /// The commanded point in world coordinates, for display (none before the first action).
  virtual std::optional<Eigen::Vector3d> target() const { return std::nullopt; }
};

/// A 2-D task seen from above (Env::plane), for a console to draw: the arena, where episodes start,
/// the goal, this episode's obstacles and the agent, in the task's plane coordinates.
struct PlaneScene {
  struct Disc {
    Eigen::Vector2d center{0, 0};
    double radius = 0;
  };
  double half = 1;  // the arena spans [-half, half] on both axes, inside its walls
  Eigen::Vector2d start_center{0, 0};
  double start_half = 0;  // episodes start in this square
  Disc goal;
  std::vector<Disc> obstacles;
  Disc agent;
};

}  // namespace dd

// MuJoCo's model and data, declared without its headers: core never includes the simulator.
struct mjModel_;
struct mjData_;

namespace dd {

/// A physics task's MuJoCo model and state (Env::physics), for a console to render. Both live as long
/// as the Env; the data changes as it steps.
struct PhysicsScene {
  const mjModel_* model = nullptr;
  const mjData_* data = nullptr;
};

class Env {
 public:
  virtual ~Env() = default;
  virtual std::string name() const = 0;
  virtual int obs_dim() const = 0;
  virtual int action_dim() const = 0;
  /// Steps before the episode ends by time (T_L by default).
  virtual int time_limit() const = 0;
  /// Changes the time limit for the current episode (reset restores the default); the DAgger
  /// session raises it so that an expert taking over at T_L can finish the task.
  virtual void set_time_limit(int steps) = 0;
  /// Control rate in Hz.
  virtual double control_hz() const = 0;

  /// Starts an episode from a random initial state drawn from `seed`.
  virtual void reset(uint64_t seed) = 0;
  /// The current observation (obs_dim).
  virtual Vec observation() const = 0;
  /// Applies one action (action_dim) for one control step.
  virtual StepResult step(const Vec& action) = 0;
  virtual bool success() const = 0;
  /// A short word on how far the episode got (for failure breakdowns): "success", or a task's
  /// stage such as "not grasped", "dropped", "held"; "failure" where a task says no more.
  virtual std::string outcome() const { return success() ? "success" : "failure"; }
  /// Steps taken in this episode.
  virtual int steps() const = 0;

  /// The full simulation state, to restore later (e.g. to replay a takeover).
  virtual std::vector<double> save_state() const = 0;
  virtual void restore_state(const std::vector<double>& state) = 0;

  /// How an operator drives this task (null: it cannot be teleoperated).
  virtual std::unique_ptr<Teleoperation> teleoperation() const { return nullptr; }

  // How a console shows the task, without knowing its type: a plane seen from above (2-D tasks) or a
  // physics scene for MuJoCo's renderer; a task with neither is not drawn.
  virtual std::optional<PlaneScene> plane() const { return std::nullopt; }
  virtual std::optional<PhysicsScene> physics() const { return std::nullopt; }
  /// The points a chunk of actions sends the agent to, one per row, in the scene's coordinates (a
  /// plane's x, y and 0; a physics scene's world x, y, z); empty where actions are not positions.
  virtual std::vector<Eigen::Vector3d> action_points(const Mat& /*chunk*/) const { return {}; }
  /// Where an observation puts the agent, in the same coordinates (for drawing demonstrations); none
  /// where the task does not say.
  virtual std::optional<Eigen::Vector3d> observed_point(const Vec& /*obs*/) const { return std::nullopt; }
  /// The observation the policy would get with the agent at rest at plane point p and the rest of this
  /// episode as it is (to map a policy's score over the plane); none where p is not free or the task
  /// has no plane.
  virtual std::optional<Vec> observation_at_rest(const Eigen::Vector2d& /*p*/) const { return std::nullopt; }
};

/// An expert that acts in an Env (a scripted controller, a planner, or a human at the console).
class Expert {
 public:
  virtual ~Expert() = default;
  virtual std::string name() const = 0;
  /// Called at the start of each episode (chooses a mode, clears plans).
  virtual void reset(uint64_t seed) = 0;
  /// The expert's action for the env's current state.
  virtual Vec act(const Env& env) = 0;
  /// The expert cannot finish the task from this state (a scripted expert's limit: the plugging
  /// planner cannot right a toppled charger). The DAgger session then ends the episode as the
  /// expert's failure at once, instead of letting it act to the time limit.
  virtual bool gave_up(const Env& /*env*/) const { return false; }

  /// Noise injected while recording demonstrations (DART, Laskey et al. 2017): expert_episode executes
  /// act() plus Gaussian noise with these standard deviations, one per action component, and records
  /// act() itself, so the data shows the expert correcting small deviations. Empty: no noise.
  Vec execution_noise;
  /// name() with "+noise" when execution_noise is set: how `collect` reports the expert.
  std::string label() const { return execution_noise.size() > 0 ? name() + "+noise" : name(); }
};

/// What a scripted expert's action becomes when executed: act() plus its execution noise, drawn from
/// one stream per episode. `collect` (expert_episode) and the DAgger session both use it, so an episode
/// seed gives the same draws in either.
class ExecutionNoise {
 public:
  /// Throws dd::Error when the expert's noise has another length than the env's actions.
  ExecutionNoise(const Expert& expert, int action_dim) : sigma_(expert.execution_noise) {
    if (sigma_.size() > 0 && sigma_.size() != action_dim)
      throw Error(expert.name() + ": execution noise has " + std::to_string(sigma_.size()) +
                  " values, the actions " + std::to_string(action_dim));
  }
  /// Starts the episode's stream.
  void reset(uint64_t episode_seed) {
    rng_.seed(episode_seed ^ 0xDA27'0000'0000'0001ull);
    normal_.reset();
  }
  /// The action as executed (unchanged when the expert has no noise).
  Vec apply(const Vec& action) {
    Vec executed = action;
    for (Eigen::Index i = 0; i < sigma_.size(); ++i) executed[i] += sigma_[i] * normal_(rng_);
    return executed;
  }

 private:
  Vec sigma_;
  std::mt19937_64 rng_;
  std::normal_distribution<float> normal_{0.f, 1.f};
};

}  // namespace dd
