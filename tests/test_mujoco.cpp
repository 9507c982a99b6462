// The MuJoCo arm tasks: models load, the IK reaches targets, the experts succeed over seeded
// episodes, trajectories are deterministic, and bad actions or an exploding simulation end the
// episode as failed without a crash.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <map>
#include <random>

#include "core/config.h"
#include "core/evaluation.h"
#include "envs/mujoco/mj_util.h"
#include "envs/mujoco/planner.h"
#include "envs/mujoco/stack.h"
#include "envs/mujoco/stack_expert.h"
#include "envs/mujoco/plug.h"
#include "envs/mujoco/plug_expert.h"
#include "envs/mujoco/push.h"
#include "envs/mujoco/push_expert.h"
#include "core/task_config.h"
#include "envs/registry.h"

#include <nlohmann/json.hpp>

namespace dd::mj {
namespace {

struct Outcome {
  bool success = false;
  int steps = 0;
};

Outcome run_expert(Env& env, Expert& expert, uint64_t seed) {
  const RecordedEpisode ep = expert_episode(env, expert, seed);
  return {ep.success, ep.steps()};
}

uint64_t state_hash(const Env& env) {
  uint64_t h = 1469598103934665603ull;
  for (double v : env.save_state()) {
    const float f = static_cast<float>(v);
    uint32_t bits;
    std::memcpy(&bits, &f, 4);
    h = (h ^ bits) * 1099511628211ull;
  }
  return h;
}

// How many of four episodes (seeds first_seed..) the expert still finishes after a robot wandered
// for `wander` steps of `random_action`, with `budget` steps left to it.
int recoveries(Env& env, Expert& expert, uint64_t first_seed, int wander, int budget,
               const std::function<Vec(std::mt19937&)>& random_action) {
  int ok = 0;
  for (int s = 0; s < 4; ++s) {
    env.reset(first_seed + s);
    std::mt19937 rng(s);
    for (int t = 0; t < wander; ++t) env.step(random_action(rng));
    expert.reset(first_seed + s);
    env.set_time_limit(env.steps() + budget);
    StepResult r;
    while (!r.done) r = env.step(expert.act(env));
    ok += env.success();
  }
  return ok;
}

// Random reachable TCP poses with the gripper toggling.
Vec random_pose(std::mt19937& rng) {
  std::uniform_real_distribution<float> u(-1, 1);
  Vec a(10);
  a.head<3>() << 0.5f + 0.1f * u(rng), 0.15f * u(rng), 0.12f + 0.05f * u(rng);
  a.segment<6>(3) = rot6d(tool_down(0.4 * u(rng))).cast<float>();
  a[9] = u(rng) > 0 ? 1.f : 0.f;
  return a;
}

// Two copies of a task stepped by two copies of its expert end in the same state.
template <typename TaskEnv, typename TaskExpert>
void expect_same_trajectory(uint64_t seed, int steps) {
  TaskEnv a, b;
  TaskExpert ea, eb;
  a.reset(seed);
  b.reset(seed);
  ea.reset(seed);
  eb.reset(seed);
  for (int t = 0; t < steps; ++t) {
    a.step(ea.act(a));
    b.step(eb.act(b));
  }
  EXPECT_EQ(state_hash(a), state_hash(b));
}

}  // namespace

TEST(Mujoco, StackModelLoadsWithTheDeclaredSizes) {
  StackEnv env;
  EXPECT_EQ(env.obs_dim(), 37);
  EXPECT_EQ(env.action_dim(), 10);
  EXPECT_EQ(env.model()->nu, 9);  // 7 joint servos, 2 finger servos
  const Vec o = env.observation();
  ASSERT_EQ(o.size(), 37);
  EXPECT_TRUE(o.allFinite());
  // the TCP starts above the table, pointing down
  EXPECT_GT(env.arm().tcp_pos(env.data()).z(), 0.15);
  EXPECT_LT(env.arm().tcp_rot(env.data())(2, 2), -0.95);
}

TEST(Mujoco, IkReachesTargetsWithinTwoMillimetres) {
  StackEnv env;
  const Eigen::Vector3d targets[] = {{0.45, 0.0, 0.10}, {0.60, 0.15, 0.05}, {0.40, -0.20, 0.20}, {0.55, 0.10, 0.02}};
  for (const auto& p : targets) {
    env.reset(1);
    const Eigen::Matrix3d R = tool_down(0.3);
    Vec a(10);
    a.head<3>() = p.cast<float>();
    a.segment<6>(3) = rot6d(R).cast<float>();
    a[9] = 0;
    for (int i = 0; i < 40; ++i) env.step(a);
    const Eigen::Vector3d reached = env.arm().tcp_pos(env.data());
    EXPECT_LT((reached - p).norm(), 0.002) << "target " << p.transpose() << " reached " << reached.transpose();
    const Eigen::AngleAxisd err(R * env.arm().tcp_rot(env.data()).transpose());
    EXPECT_LT(err.angle(), 0.02);
  }
}

TEST(Mujoco, StackExpertSucceedsOverSeededEpisodes) {
  StackEnv env;
  StackExpert expert;
  int ok = 0, steps = 0;
  const int n = 10;
  for (int s = 0; s < n; ++s) {
    const Outcome o = run_expert(env, expert, 100 + s);
    ok += o.success;
    if (o.success) steps += o.steps;
  }
  std::printf("stack expert: %d/%d, mean %.1f steps\n", ok, n, ok ? double(steps) / ok : 0.0);
  EXPECT_GE(ok, 9);
}

TEST(Mujoco, StackExpertTakesOverMidEpisode) {
  StackEnv env;
  StackExpert expert;
  EXPECT_GE(recoveries(env, expert, 300, 30, 250, random_pose), 3);
}

TEST(Mujoco, StackIsDeterministic) { expect_same_trajectory<StackEnv, StackExpert>(7, 60); }

TEST(Mujoco, StackContinuesFromARestoredState) {
  StackEnv a;
  StackExpert ea;
  a.reset(7);
  ea.reset(7);
  for (int t = 0; t < 60; ++t) a.step(ea.act(a));
  // restoring a saved state continues the same trajectory (to rounding: MuJoCo recomputes derived
  // quantities on restore)
  const auto saved = a.save_state();
  const Vec act = ea.act(a);
  a.step(act);
  const auto after = a.save_state();
  a.restore_state(saved);
  a.step(act);
  const auto again = a.save_state();
  ASSERT_EQ(after.size(), again.size());
  double worst = 0;
  for (size_t i = 0; i < after.size(); ++i) worst = std::max(worst, std::abs(after[i] - again[i]));
  EXPECT_LT(worst, 1e-9);
}

TEST(Mujoco, NonFiniteActionEndsTheEpisodeAsFailed) {
  StackEnv env;
  env.reset(3);
  Vec a = Vec::Zero(10);
  a[0] = NAN;
  const StepResult r = env.step(a);
  EXPECT_TRUE(r.done);
  EXPECT_TRUE(r.failed);
  EXPECT_NE(r.warning.find("non-finite"), std::string::npos);
  EXPECT_TRUE(env.step(Vec::Zero(10)).done);  // stays over
}

TEST(Mujoco, ExplodingSimulationEndsTheEpisodeAsFailed) {
  StackEnv env;
  env.reset(4);
  env.mutable_data()->qvel[0] = 1e9;  // an absurd joint velocity
  StepResult r;
  Vec a(10);
  a.head<3>() << 0.5f, 0.f, 0.2f;
  a.segment<6>(3) = rot6d(tool_down(0)).cast<float>();
  a[9] = 0;
  for (int i = 0; i < 5 && !r.done; ++i) r = env.step(a);
  EXPECT_TRUE(r.done);
  EXPECT_TRUE(r.failed);
  EXPECT_NE(r.warning.find("unstable"), std::string::npos) << r.warning;
}

TEST(Mujoco, PlugModelLoadsWithTheDeclaredSizes) {
  PlugEnv env;
  EXPECT_EQ(env.obs_dim(), 37);
  EXPECT_EQ(env.action_dim(), 10);
  const Vec o = env.observation();
  ASSERT_EQ(o.size(), 37);
  EXPECT_TRUE(o.allFinite());
  // 1 mm clearance a side between prong and socket, and the charger starts out of the socket
  EXPECT_NEAR(env.config().socket_half - env.config().prong_half, 0.001, 1e-9);
  EXPECT_FALSE(env.inserted());
}

TEST(Mujoco, PlugExpertInsertsOverSeededEpisodes) {
  PlugEnv env;
  PlugExpert expert;
  int ok = 0, steps = 0;
  const int n = 6;
  for (int s = 0; s < n; ++s) {
    const Outcome o = run_expert(env, expert, 200 + s);
    ok += o.success;
    if (o.success) steps += o.steps;
  }
  std::printf("plug expert: %d/%d, mean %.1f steps\n", ok, n, ok ? double(steps) / ok : 0.0);
  EXPECT_GE(ok, 5);
}

TEST(Mujoco, PlugExpertsDetoursLeaveTheStraightLineAndStillInsert) {
  PlugEnv env;
  const auto detouring = make_expert("plug", "detour"), straight = make_expert("plug", "planner");
  EXPECT_EQ(detouring->name(), "plug_detour");  // as `collect` reports it
  EXPECT_EQ(straight->name(), "plug_planner");
  EXPECT_EQ(make_expert("plug", "detour+noise")->label(), "plug_detour+noise");
  for (uint64_t seed : {300, 301}) {
    const RecordedEpisode a = expert_episode(env, *detouring, seed), b = expert_episode(env, *straight, seed);
    EXPECT_TRUE(a.success) << seed;
    EXPECT_TRUE(b.success) << seed;
    // the commanded TCP positions (actions 0-2) part by about the detour somewhere on the way
    double apart = 0;
    for (Eigen::Index t = 0; t < std::min(a.steps(), b.steps()); ++t)
      apart = std::max(apart, double((a.actions.row(t).head(2) - b.actions.row(t).head(2)).norm()));
    EXPECT_GT(apart, 0.01) << seed;  // the "detour" mode goes 1-2 cm beside the straight line
  }
}

TEST(Mujoco, PlugExpertTakesOverMidEpisode) {
  PlugEnv env;
  PlugExpert expert;
  EXPECT_GE(recoveries(env, expert, 500, 30, 500, random_pose), 3);
}

// Poses the charger upright at the socket's yaw, `offset` off the socket's centre along the socket's
// x axis, its prong's tip `depth` below the receptacle's top, and asks MuJoCo's collision detection
// whether the prong then cuts into the receptacle.
bool prong_cuts_the_receptacle(double chamfer, double offset, double depth) {
  PlugConfig config;
  config.chamfer = chamfer;
  PlugEnv env(config);
  env.reset(3);
  mjData* d = env.mutable_data();
  const mjModel* m = env.model();
  const double yaw = env.socket_yaw(), top = env.seated_height() - 0.015;  // handle half-height 15 mm
  const Eigen::Vector3d at = env.socket_pos() + Eigen::Vector3d(std::cos(yaw), std::sin(yaw), 0) * offset +
                             Eigen::Vector3d(0, 0, env.seated_height() + 0.030 - depth);  // prong 30 mm long
  set_free_pose(m, d, mj_name2id(m, mjOBJ_BODY, "charger"), at, Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ())));
  mj_forward(m, d);
  const int prong = mj_name2id(m, mjOBJ_GEOM, "prong"), receptacle = mj_name2id(m, mjOBJ_BODY, "receptacle");
  EXPECT_NEAR(env.charger_pos().z() - 0.030 - 0.015, top - depth, 1e-9);
  for (int i = 0; i < d->ncon; ++i) {
    const mjContact& c = d->contact[i];
    const bool pair = (c.geom1 == prong && m->geom_bodyid[c.geom2] == receptacle) || (c.geom2 == prong && m->geom_bodyid[c.geom1] == receptacle);
    if (pair && c.dist < -1e-4) return true;
  }
  return false;
}

TEST(Mujoco, PlugChamferWidensTheSocketsMouthAndKeepsItsClearance) {
  // 3 mm off centre (three times the 1 mm clearance, about the learned policies' median error in
  // results/bc_curves/plug), 2 mm into the socket: the prong sits on the wall's top without a lead-in
  // and inside the 5 mm chamfer with one
  EXPECT_TRUE(prong_cuts_the_receptacle(0.0, 0.003, 0.002));
  EXPECT_FALSE(prong_cuts_the_receptacle(0.005, 0.003, 0.002));
  // below the chamfer the socket is as tight as before: 3 mm off cuts the wall, centred does not
  EXPECT_TRUE(prong_cuts_the_receptacle(0.005, 0.003, 0.010));
  EXPECT_FALSE(prong_cuts_the_receptacle(0.005, 0.0, 0.010));
  EXPECT_FALSE(prong_cuts_the_receptacle(0.005, 0.0009, 0.025));
  EXPECT_GT(PlugConfig{}.chamfer, 0.0);  // the task's default has the lead-in
}

// Poses the charger with its origin at `at` and rotation `q`, at rest, and updates the derived state.
void pose_charger(PlugEnv& env, const Eigen::Vector3d& at, const Eigen::Quaterniond& q) {
  mjData* d = env.mutable_data();
  const mjModel* m = env.model();
  const int body = mj_name2id(m, mjOBJ_BODY, "charger");
  set_free_pose(m, d, body, at, q);  // at rest
  mj_forward(m, d);
}

TEST(Mujoco, PlugCountsOnlyAnUprightChargerAsInserted) {
  PlugEnv env;
  env.reset(5);
  PlugExpert expert;
  const double yaw = env.socket_yaw();
  const Eigen::Vector3d seated(env.socket_pos().x(), env.socket_pos().y(), env.seated_height());
  const Eigen::Quaterniond upright(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()));
  pose_charger(env, seated, upright);
  EXPECT_TRUE(env.inserted());
  EXPECT_NEAR(env.charger_tilt(), 0, 1e-6);
  EXPECT_FALSE(env.toppled());
  EXPECT_FALSE(expert.gave_up(env));
  // upside down, its handle on the receptacle: the origin is at the seated height, the prong in the
  // air (RQ2 runs on plugging counted this as inserted)
  pose_charger(env, seated, upright * Eigen::Quaterniond(Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX())));
  EXPECT_FALSE(env.inserted());
  EXPECT_NEAR(env.charger_tilt(), M_PI, 1e-6);
  EXPECT_EQ(env.outcome(), "toppled");
  EXPECT_TRUE(env.toppled());
  EXPECT_TRUE(expert.gave_up(env));
  // on its side beside the socket, at rest: toppled; the same pose while it is still falling is not yet
  const Eigen::Vector3d beside = seated + Eigen::Vector3d(0.1, 0, 0);
  pose_charger(env, beside, upright * Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitX())));
  EXPECT_TRUE(env.toppled());
  EXPECT_TRUE(expert.gave_up(env));
  Eigen::Matrix<double, 6, 1> turning = Eigen::Matrix<double, 6, 1>::Zero();
  turning[3] = 2.0;  // 2 rad/s
  set_free_vel(env.model(), env.mutable_data(), mj_name2id(env.model(), mjOBJ_BODY, "charger"), turning);
  EXPECT_FALSE(env.toppled());
  // a little tilted (10 degrees), at rest: the expert goes on
  pose_charger(env, beside, upright * Eigen::Quaterniond(Eigen::AngleAxisd(10 * M_PI / 180, Eigen::Vector3d::UnitX())));
  EXPECT_FALSE(env.toppled());
  EXPECT_FALSE(expert.gave_up(env));
}

// The charger's tilt [rad] after a sideways push of `newtons` at its centre of mass for 0.3 s and 1 s
// to settle, standing in its dock or, with `in_dock` false, free on the table 12 cm beside it. The arm
// holds its pose above.
double tilt_after_push(bool in_dock, double newtons) {
  PlugEnv env;
  env.reset(11);
  const mjModel* m = env.model();
  mjData* d = env.mutable_data();
  const int body = mj_name2id(m, mjOBJ_BODY, "charger");
  if (!in_dock) pose_charger(env, env.charger_pos() - Eigen::Vector3d(0, 0.12, 0), Eigen::Quaterniond::Identity());
  Vec hold(10);
  hold.head<3>() = env.arm().tcp_pos(d).cast<float>();
  hold.segment<6>(3) = rot6d(tool_down(0)).cast<float>();
  hold[9] = 0;
  for (int t = 0; t < 26; ++t) {
    d->xfrc_applied[6 * body] = t < 6 ? newtons : 0.0;  // 20 Hz control: 6 steps are 0.3 s
    env.step(hold);
  }
  return env.charger_tilt();
}

TEST(Mujoco, PlugDockHoldsTheChargerUprightWhereTheTableWouldNot) {
  // the push tips a charger standing free (its centre of mass is 39 mm up, its prong 18 mm wide)
  EXPECT_GT(tilt_after_push(false, 0.3), PlugEnv::kToppled);
  // in the dock the prong meets a wall after about 2 degrees, and the charger settles back upright
  EXPECT_LT(tilt_after_push(true, 0.3), 3 * M_PI / 180);
  EXPECT_LT(tilt_after_push(true, 1.0), 3 * M_PI / 180);
  // with 1 mm to spare a side, as the socket
  EXPECT_NEAR(PlugConfig{}.dock_half - PlugConfig{}.prong_half, 0.001, 1e-9);
}

TEST(Mujoco, PlugIsDeterministic) { expect_same_trajectory<PlugEnv, PlugExpert>(9, 80); }

TEST(Mujoco, PushModelLoadsWithTheDeclaredSizes) {
  PushEnv env;
  EXPECT_EQ(env.obs_dim(), 24);
  EXPECT_EQ(env.action_dim(), 7);
  const Vec o = env.observation();
  ASSERT_EQ(o.size(), 24);
  EXPECT_TRUE(o.allFinite());
  EXPECT_FALSE(env.at_goal());  // it starts about half a turn away
  // the block-frame features turned back by the block's yaw are the world differences
  const Eigen::Vector3d b = env.block();
  const Eigen::Rotation2Dd R(b.z());
  const Eigen::Vector2d tip = b.head<2>() + R * Eigen::Vector2d(o[20], o[21]);
  const Eigen::Vector2d goal = b.head<2>() + R * Eigen::Vector2d(o[22], o[23]);
  EXPECT_LT((tip - env.arm().tcp_pos(env.data()).head<2>()).norm(), 1e-5);
  EXPECT_LT((goal - env.config().goal.head<2>()).norm(), 1e-5);
  // joint deltas are clipped: a huge action moves each joint by at most max_joint_step
  const Vec7 q0 = env.arm().q(env.data());
  env.step(Vec::Constant(7, 10.f));
  const Vec7 q1 = env.arm().q(env.data());
  EXPECT_LT((q1 - q0).cwiseAbs().maxCoeff(), env.max_joint_step + 0.01);
}

TEST(Mujoco, PushExpertsTurnTheBlockTheirOwnWayHome) {
  PushEnv env;
  for (auto mode : {PushExpert::Mode::kClockwise, PushExpert::Mode::kCounterClockwise}) {
    PushExpert expert(mode);
    int ok = 0, steps = 0;
    const int n = 5;
    for (int s = 0; s < n; ++s) {
      env.reset(400 + s);
      expert.reset(400 + s);
      // follow the unwrapped yaw: the sense of rotation must be the expert's
      double yaw = env.block().z(), travelled = 0;
      StepResult r;
      while (!r.done) {
        r = env.step(expert.act(env));
        const double now = env.block().z();
        travelled += std::remainder(now - yaw, 2 * M_PI);
        yaw = now;
      }
      if (env.success()) {
        ++ok;
        steps += env.steps();
        if (mode == PushExpert::Mode::kClockwise) EXPECT_LT(travelled, -2.0) << "seed " << 400 + s;
        else EXPECT_GT(travelled, 2.0) << "seed " << 400 + s;
      }
    }
    std::printf("push expert %s: %d/%d, mean %.1f steps\n", expert.name().c_str(), ok, n, ok ? double(steps) / ok : 0.0);
    EXPECT_GE(ok, 4) << expert.name();
  }
}

TEST(Mujoco, PushExpertWithNoiseRecordsItsCleanActionsNotTheExecutedOnes) {
  PushEnv env;
  const auto clean = make_expert("push", "cw"), noisy = make_expert("push", "cw+noise");
  EXPECT_EQ(noisy->label(), "push_cw+noise");
  ASSERT_EQ(noisy->execution_noise.size(), 7);
  EXPECT_GT(noisy->execution_noise.minCoeff(), 0.0f);
  EXPECT_THROW(make_expert("push", "sideways+noise"), Error);
  const uint64_t seed = 410;
  const RecordedEpisode a = expert_episode(env, *clean, seed), b = expert_episode(env, *noisy, seed);
  const RecordedEpisode b2 = expert_episode(env, *noisy, seed);
  EXPECT_TRUE(a.success);
  EXPECT_TRUE(b.success);
  EXPECT_TRUE(b.obs.isApprox(b2.obs)) << "the noise is seeded by the episode";
  ASSERT_GT(std::min(a.steps(), b.steps()), 20);
  EXPECT_GT((a.obs.topRows(20) - b.obs.topRows(20)).cwiseAbs().maxCoeff(), 1e-3) << "the noise moved the arm";
  // replaying the recorded actions open loop reproduces a clean episode's states, but not a noisy
  // one's: what was recorded is the expert's action, not the executed one
  auto replay_error = [&](const RecordedEpisode& e) {
    env.reset(seed);
    double err = 0;
    for (Eigen::Index t = 0; t < 20; ++t) {
      err = std::max(err, double((env.observation() - Vec(e.obs.row(t).transpose())).cwiseAbs().maxCoeff()));
      env.step(e.actions.row(t).transpose());
    }
    return err;
  };
  EXPECT_LT(replay_error(a), 1e-5);
  EXPECT_GT(replay_error(b), 1e-3);
}

TEST(Mujoco, PushExpertTakesOverMidEpisode) {
  PushEnv env;
  PushExpert expert(PushExpert::Mode::kCounterClockwise);
  const auto jiggle = [](std::mt19937& rng) {  // random joint jiggles
    std::uniform_real_distribution<float> u(-1, 1);
    Vec a(7);
    for (int j = 0; j < 7; ++j) a[j] = 0.05f * u(rng);
    return a;
  };
  EXPECT_GE(recoveries(env, expert, 600, 25, 250, jiggle), 3);
}

TEST(Mujoco, MixedPushExpertUsesBothSenses) {
  PushExpert expert(PushExpert::Mode::kMixed);
  int cw = 0;
  for (int s = 0; s < 40; ++s) {
    expert.reset(s);
    cw += expert.episode_mode() == PushExpert::Mode::kClockwise;
  }
  EXPECT_GT(cw, 10);
  EXPECT_LT(cw, 30);
}

TEST(Mujoco, AlternatingPushExpertsTakeTurns) {
  // push_2experts: consecutive episodes (consecutive seeds) alternate between the two senses
  auto expert = make_expert("push", "alternate");
  auto* push = dynamic_cast<PushExpert*>(expert.get());
  ASSERT_NE(push, nullptr);
  for (uint64_t s = 100; s < 110; ++s) {
    push->reset(s);
    EXPECT_EQ(push->episode_mode(), s % 2 == 0 ? PushExpert::Mode::kClockwise : PushExpert::Mode::kCounterClockwise) << s;
  }
  EXPECT_THROW(make_expert("push", "sideways"), Error);
}

TEST(Mujoco, OutcomesSayHowFarAnEpisodeGot) {
  StackEnv stack;
  stack.reset(3);
  EXPECT_EQ(stack.outcome(), "not grasped");
  StackExpert expert;
  expert.reset(3);
  while (!stack.step(expert.act(stack)).done) {
  }
  EXPECT_EQ(stack.outcome(), "success");
  PushEnv push;
  push.reset(3);
  EXPECT_EQ(push.outcome(), "far");  // half a turn from home
  PlugEnv plug;
  plug.reset(3);
  EXPECT_EQ(plug.outcome(), "in the dock");
}

TEST(Mujoco, PlannerGoesAroundAnObstacle) {
  const std::vector<Box3> wall = {{{0.45, -0.1, 0.0}, {0.5, 0.1, 0.4}}};
  const Eigen::Vector3d a(0.3, 0, 0.1), b(0.7, 0, 0.1);
  const auto path = plan_path(a, b, wall, 1);
  ASSERT_GE(path.size(), 3u);
  EXPECT_TRUE(path.front().isApprox(a));
  EXPECT_TRUE(path.back().isApprox(b));
  for (size_t i = 1; i < path.size(); ++i) EXPECT_TRUE(segment_free(path[i - 1], path[i], wall, PlannerConfig{}));
}

TEST(Mujoco, RegistryBuildsTheArmTasks) {
  for (const std::string task : {"stack", "push", "plug"}) {
    auto env = make_env(task);
    auto expert = make_expert(task, task == "push" ? "cw" : "planner");
    EXPECT_EQ(env->name(), task);
    EXPECT_THROW(make_expert(task, "sideways"), Error);
  }
}

TEST(ArmTeleoperation, TheTargetStartsAtTheToolMovesWithTheViewAndTheGripperToggles) {
  StackEnv env;
  env.reset(3);
  auto teleop = env.teleoperation();
  ASSERT_TRUE(teleop);
  EXPECT_FALSE(teleop->target());  // nothing commanded before the first action
  teleop->begin();
  const Eigen::Vector3d tcp = env.arm().tcp_pos(env.data());
  OperatorInput in;
  Vec a = teleop->action(env, in);
  ASSERT_EQ(a.size(), env.action_dim());
  EXPECT_LT((a.head<3>().cast<double>() - tcp).norm(), 1e-5);  // holds the tool where it is
  const float grip = a[9];
  // jogging "up" moves the target 1 cm along the view's forward direction, here world -y
  in.forward = Eigen::Vector2d(0, -1);
  in.jog = Eigen::Vector2d(0, 1);
  a = teleop->action(env, in);
  EXPECT_NEAR(a[1], tcp.y() - 0.01, 1e-5);
  EXPECT_NEAR(a[0], tcp.x(), 1e-5);
  // a dragged target far away is approached within reach (8 cm of the tool)
  in = OperatorInput{};
  in.has_target = true;
  in.target = tcp.head<2>() + Eigen::Vector2d(0.5, 0);
  a = teleop->action(env, in);
  EXPECT_NEAR((a.head<3>().cast<double>() - tcp).norm(), 0.08, 1e-4);
  teleop->toggle_grip();
  EXPECT_NE(teleop->action(env, OperatorInput{})[9], grip);
  // a new takeover starts again from the tool
  teleop->begin();
  EXPECT_LT((teleop->action(env, OperatorInput{}).head<3>().cast<double>() - tcp).norm(), 1e-5);
}

TEST(Mujoco, ArmTasksDescribeAPhysicsSceneAndTheirChunksAsTcpPoints) {
  StackEnv env;
  env.reset(3);
  const std::optional<PhysicsScene> physics = env.physics();
  ASSERT_TRUE(physics);
  EXPECT_EQ(physics->model, env.model());
  EXPECT_EQ(physics->data, env.data());
  EXPECT_FALSE(env.plane());
  EXPECT_FALSE(env.observation_at_rest({0, 0}));
  ASSERT_EQ(env.control(), ArmControl::kEndEffectorPose);
  Mat chunk = Mat::Zero(4, env.action_dim());
  for (int r = 0; r < 4; ++r) chunk.row(r).head<3>() << 0.4f + 0.01f * r, -0.1f, 0.2f;
  const auto points = env.action_points(chunk);
  ASSERT_EQ(points.size(), 4u);
  EXPECT_TRUE(points[3].isApprox(Eigen::Vector3d(0.43, -0.1, 0.2), 1e-6));
}

}  // namespace dd::mj

namespace dd {

TEST(TaskRegistry, EveryRowBuildsItsEnvExpertsAndTeleoperationToMatchItsPreset) {
  for (const TaskInfo& t : task_registry()) {
    SCOPED_TRACE(t.name);
    auto env = make_env(t.name);
    EXPECT_EQ(env->name(), t.name);
    EXPECT_TRUE(env->teleoperation()) << "every task can be driven by an operator";
    const ExperimentConfig c = preset(t.preset);
    EXPECT_EQ(c.task, t.name);
    EXPECT_EQ(c.policy.obs_dim, env->obs_dim());
    EXPECT_EQ(c.policy.action_dim, env->action_dim());
    for (const std::string& mode : t.expert_modes) EXPECT_TRUE(make_expert(t.name, mode)) << mode;
    if (t.expert_noise.size() > 0) {
      EXPECT_EQ(t.expert_noise.size(), env->action_dim());
      EXPECT_EQ(make_expert(t.name, t.expert_modes.back() + "+noise")->execution_noise, t.expert_noise);
    } else {
      EXPECT_THROW(make_expert(t.name, "mixed+noise"), Error);
    }
    const nlohmann::json args = nlohmann::json::parse(env_args(t.name));
    EXPECT_EQ(args.at("env_name").get<std::string>(), t.name);
  }
  auto message = [](const std::function<void()>& f) {
    try {
      f();
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(message([] { make_env("fold"); }), "unknown task 'fold' (known: nav2d, nav2d_random, stack, push, plug)");
  EXPECT_EQ(message([] { make_expert("push", "zigzag"); }), "push expert: unknown mode 'zigzag' (known: mixed, cw, ccw, alternate; each with +noise)");
}

}  // namespace dd

