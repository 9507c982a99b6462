// The 2-D navigation toy: expert success in both modes, determinism pinned by a state hash, region
// labels of hand-placed states, and bad actions ending the episode instead of crashing.
#include <gtest/gtest.h>
#include <spdlog/spdlog.h>

#include <cstdio>
#include <cstring>

#include "envs/nav2d.h"
#include "envs/nav2d_expert.h"

namespace dd {
namespace {

struct Rollout {
  bool success = false;
  int steps = 0;
  double min_y = 0, max_y = 0;  // which side of the obstacle it went
};

Rollout run_expert(Nav2dEnv& env, Nav2dExpert& expert, uint64_t seed) {
  env.reset(seed);
  expert.reset(seed);
  Rollout r;
  for (int i = 0; i < env.time_limit(); ++i) {
    const StepResult s = env.step(expert.act(env));
    r.min_y = std::min(r.min_y, env.position().y());
    r.max_y = std::max(r.max_y, env.position().y());
    if (s.done) break;
  }
  r.success = env.success();
  r.steps = env.steps();
  return r;
}

// FNV-1a over the bytes of every observation of a trajectory.
uint64_t trajectory_hash(uint64_t seed) {
  Nav2dEnv env;
  Nav2dExpert expert(Nav2dExpert::Mode::kClockwise);
  env.reset(seed);
  uint64_t h = 1469598103934665603ull;
  for (int i = 0; i < 60; ++i) {
    env.step(expert.act(env));
    const Vec o = env.observation();
    const auto* bytes = reinterpret_cast<const unsigned char*>(o.data());
    for (size_t k = 0; k < sizeof(float) * 4; ++k) h = (h ^ bytes[k]) * 1099511628211ull;
  }
  return h;
}

}  // namespace

TEST(Nav2dExpert, SucceedsInBothModesFromSeededStarts) {
  Nav2dEnv env;
  for (auto mode : {Nav2dExpert::Mode::kClockwise, Nav2dExpert::Mode::kCounterClockwise}) {
    Nav2dExpert expert(mode);
    int ok = 0, right_side = 0;
    for (uint64_t seed = 0; seed < 100; ++seed) {
      const Rollout r = run_expert(env, expert, seed);
      ok += r.success;
      // Clockwise goes over the top of the obstacle, counter-clockwise underneath.
      right_side += mode == Nav2dExpert::Mode::kClockwise ? r.max_y > 0.5 : r.min_y < -0.5;
    }
    std::printf("%s: %d/100 successful\n", expert.name().c_str(), ok);
    EXPECT_GE(ok, 98) << expert.name();
    EXPECT_EQ(right_side, 100) << expert.name();
  }
}

TEST(Nav2dExpert, SucceedsWhenTheObstacleMoves) {
  Nav2dEnv env(nav2d_random_config());
  EXPECT_EQ(env.obs_dim(), 6);
  for (auto mode : {Nav2dExpert::Mode::kClockwise, Nav2dExpert::Mode::kCounterClockwise}) {
    Nav2dExpert expert(mode, nav2d_random_config());
    int ok = 0;
    double moved = 0;
    for (uint64_t seed = 0; seed < 100; ++seed) {
      ok += run_expert(env, expert, seed).success;
      moved = std::max(moved, env.obstacle_center().norm());
      EXPECT_EQ(env.observation().tail(2).cast<double>(), env.obstacle_center().cast<float>().cast<double>());
    }
    std::printf("%s with a moving obstacle: %d/100 successful\n", expert.name().c_str(), ok);
    EXPECT_GE(ok, 98) << expert.name();
    EXPECT_GT(moved, 0.1);  // the obstacle really moves between episodes
  }
}

TEST(Nav2dExpert, MixedDataHasBothModes) {
  Nav2dEnv env;
  Nav2dExpert expert(Nav2dExpert::Mode::kMixed);
  int cw = 0, ok = 0;
  for (uint64_t seed = 0; seed < 100; ++seed) {
    const Rollout r = run_expert(env, expert, seed);
    ok += r.success;
    cw += expert.episode_mode() == Nav2dExpert::Mode::kClockwise;
  }
  EXPECT_GE(ok, 98);
  EXPECT_GE(cw, 30);
  EXPECT_LE(cw, 70);
}

TEST(Nav2dExpert, TakesOverFromStatesOffItsPath) {
  Nav2dEnv env;
  Nav2dExpert expert(Nav2dExpert::Mode::kCounterClockwise);
  const Vec2 starts[] = {{-0.2, 0.9}, {0.0, -1.0}, {-1.0, 1.0}, {-0.6, -0.2}, {1.0, 1.0}};
  for (const Vec2& p : starts) {
    env.reset(1);
    env.set_agent(p, Vec2(0.3, -0.2));
    for (int i = 0; i < env.time_limit() && !env.step(expert.act(env)).done; ++i) {
    }
    EXPECT_TRUE(env.success()) << p.transpose();
  }
}

TEST(Nav2dEnv, IsDeterministic) {
  EXPECT_EQ(trajectory_hash(7), trajectory_hash(7));
  EXPECT_NE(trajectory_hash(7), trajectory_hash(8));
  // Pinned: a change here means trajectories changed (Box2D version, controller, or start sampling).
  EXPECT_EQ(trajectory_hash(7), 14523941074142646310ull);
}

TEST(Nav2dEnv, SaveRestoreReplaysTheSameSteps) {
  Nav2dEnv env;
  Nav2dExpert expert(Nav2dExpert::Mode::kClockwise);
  env.reset(3);
  for (int i = 0; i < 10; ++i) env.step(expert.act(env));
  const auto saved = env.save_state();
  for (int i = 0; i < 5; ++i) env.step(expert.act(env));
  const Vec after = env.observation();
  env.restore_state(saved);
  EXPECT_EQ(env.steps(), 10);
  for (int i = 0; i < 5; ++i) env.step(expert.act(env));
  EXPECT_TRUE(env.observation().isApprox(after, 1e-4f));
  EXPECT_ANY_THROW(env.restore_state({1.0, 2.0}));
}

TEST(Nav2dEnv, NonFiniteActionFailsTheEpisode) {
  spdlog::set_level(spdlog::level::off);
  Nav2dEnv env;
  env.reset(0);
  Vec a(2);
  a << NAN, 0.f;
  const StepResult r = env.step(a);
  EXPECT_TRUE(r.done);
  EXPECT_TRUE(r.failed);
  EXPECT_FALSE(r.warning.empty());
  EXPECT_TRUE(env.step(Vec::Zero(2)).done);  // stays over
  spdlog::set_level(spdlog::level::warn);
}

TEST(Nav2dRegions, LabelsHandPlacedStates) {
  const Nav2dRegions regions;
  EXPECT_EQ(regions.label({-0.9, 0.0}), Nav2dRegion::kMultiModal);   // where the paths diverge
  EXPECT_EQ(regions.label({-0.85, 0.05}), Nav2dRegion::kMultiModal);
  EXPECT_EQ(regions.label({0.0, 0.65}), Nav2dRegion::kUniModal);     // top of the clockwise orbit
  EXPECT_EQ(regions.label({0.0, -0.65}), Nav2dRegion::kUniModal);    // bottom of the other
  EXPECT_EQ(regions.label({-1.05, 1.05}), Nav2dRegion::kOutOfDistribution);  // far corner
  EXPECT_EQ(regions.label({0.9, -1.05}), Nav2dRegion::kOutOfDistribution);
  EXPECT_EQ(regions.label({0.0, 0.0}), Nav2dRegion::kNone);          // inside the obstacle
  EXPECT_EQ(region_name(Nav2dRegion::kOutOfDistribution), "ood");
}

TEST(Nav2dEnv, TeleoperationCommandsATargetPosition) {
  Nav2dEnv env;
  env.reset(4);
  auto teleop = env.teleoperation();
  ASSERT_TRUE(teleop);
  teleop->begin();
  OperatorInput in;
  in.jog = Eigen::Vector2d(1, 0);
  Vec a = teleop->action(env, in);
  ASSERT_EQ(a.size(), env.action_dim());
  EXPECT_NEAR(a[0], env.position().x() + 0.2, 1e-5);  // a step along the jog
  EXPECT_NEAR(a[1], env.position().y(), 1e-5);
  in.has_target = true;
  in.target = Eigen::Vector2d(0.3, -0.4);
  a = teleop->action(env, in);
  EXPECT_FLOAT_EQ(a[0], 0.3f);  // the dragged point itself
  EXPECT_FLOAT_EQ(a[1], -0.4f);
}

TEST(Nav2dEnv, DescribesItsPlaneAndTheObservationAtRestAnywhere) {
  Nav2dEnv env(nav2d_random_config());
  env.reset(11);
  for (int i = 0; i < 5; ++i) env.step(env.observation().head<2>() + Vec::Constant(2, 0.05f));
  const std::optional<PlaneScene> plane = env.plane();
  ASSERT_TRUE(plane);
  EXPECT_FALSE(env.physics());
  EXPECT_DOUBLE_EQ(plane->half, env.config().arena_half);
  ASSERT_EQ(plane->obstacles.size(), 1u);
  EXPECT_EQ(plane->obstacles[0].center, env.obstacle_center());  // this episode's, not the default
  EXPECT_EQ(plane->agent.center, env.position());
  EXPECT_DOUBLE_EQ(plane->goal.radius, env.config().goal_radius);
  // at rest where the agent is, the observation is the env's own with the velocity zeroed
  const std::optional<Vec> here = env.observation_at_rest(env.position());
  ASSERT_TRUE(here);
  Vec expected = env.observation();
  expected.segment<2>(2).setZero();
  EXPECT_TRUE(here->isApprox(expected)) << here->transpose() << " vs " << expected.transpose();
  EXPECT_FALSE(env.observation_at_rest(env.obstacle_center()));  // inside the obstacle: no such state
  EXPECT_FALSE(env.observation_at_rest({5, 5}));                 // beyond the walls
  // actions and observations start with plane positions
  Mat chunk(3, 2);
  chunk << 0.1f, 0.2f, 0.3f, 0.4f, 0.5f, 0.6f;
  const auto points = env.action_points(chunk);
  ASSERT_EQ(points.size(), 3u);
  EXPECT_TRUE(points[2].isApprox(Eigen::Vector3d(0.5, 0.6, 0), 1e-6));
  EXPECT_TRUE(env.observed_point(env.observation())->head<2>().isApprox(env.position(), 1e-5));
}

}  // namespace dd
