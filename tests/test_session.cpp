// The DAgger session as a state machine, driven with a fake task and a scripted method: queries
// after exactly K violations in a row, time-limit hand-over, updates after N_d interventions, the
// stop at N_f, and the order of events.
#include <gtest/gtest.h>

#include <algorithm>
#include <deque>
#include <filesystem>

#include "core/config.h"
#include "core/dataset.h"
#include "core/evaluation.h"
#include "core/session.h"
#include "tests/fakes.h"

namespace dd {
namespace {

using fakes::LineEnv;

class ForwardExpert : public Expert {
 public:
  std::string name() const override { return "forward"; }
  void reset(uint64_t) override {}
  Vec act(const Env&) override { return Vec::Ones(1); }
};

// Fails (stands still) in the episodes listed, by their count of resets; else moves forward.
class FailingExpert : public Expert {
 public:
  explicit FailingExpert(std::vector<int> failing) : failing_(std::move(failing)) {}
  std::string name() const override { return "failing"; }
  void reset(uint64_t) override { ++episode_; }
  Vec act(const Env&) override {
    const bool fail = std::find(failing_.begin(), failing_.end(), episode_) != failing_.end();
    return Vec::Constant(1, fail ? 0.f : 1.f);
  }

 private:
  std::vector<int> failing_;
  int episode_ = 0;
};

// Decides from a script of verdicts; its chunks move at `speed`. Counts updates.
class ScriptedMethod : public Method {
 public:
  explicit ScriptedMethod(std::deque<bool> verdicts, float speed = 1.f, bool gated = true)
      : verdicts_(std::move(verdicts)), speed_(speed), gated_(gated) {}
  std::string name() const override { return "scripted"; }
  bool gated() const override { return gated_; }
  UpdateReport update(const std::vector<Episode>& expert, const std::vector<RecordedEpisode>& robot, const TrainConfig&,
                      const ProgressFn& progress) override {
    update_sizes.push_back(static_cast<int>(expert.size()));
    last_robot = robot;
    if (progress) progress(1, 1, 0.0);
    UpdateReport r;
    r.threshold = 0.5f;
    return r;
  }
  MethodDecision decide(const Vec&, uint64_t) override {
    MethodDecision d;
    d.chunk = Mat::Constant(8, 1, speed_);
    d.violation = verdicts_.empty() ? false : verdicts_.front();
    if (!verdicts_.empty()) verdicts_.pop_front();
    d.score = d.violation ? 1.f : 0.f;
    d.threshold = 0.5f;
    return d;
  }
  float threshold() const override { return 0.5f; }
  void save(const std::string&) const override {}
  std::vector<int> update_sizes;
  std::vector<RecordedEpisode> last_robot;  // the robot data of the last update

 private:
  std::deque<bool> verdicts_;
  float speed_;
  bool gated_;
};

DaggerConfig small_config() {
  DaggerConfig c;
  c.initial_demos = 1;
  c.final_demos = 3;
  c.demos_per_update = 1;
  c.patience = 2;
  c.time_limit = 20;
  c.action_steps = 2;
  return c;
}

TrainConfig no_training() {
  TrainConfig t;
  t.steps = 0;
  return t;
}

struct Recorder {
  std::vector<SessionEvent> events;
  SessionObserver fn() {
    return [this](const SessionEvent& e) {
      if (e.kind != EventKind::kUpdateProgress) events.push_back(e);
    };
  }
  std::vector<EventKind> kinds() const {
    std::vector<EventKind> k;
    for (const auto& e : events) k.push_back(e.kind);
    return k;
  }
  int count(EventKind k) const {
    int n = 0;
    for (const auto& e : events) n += e.kind == k;
    return n;
  }
};

void run_to_end(DaggerSession& s, int max_ticks = 10000) {
  for (int i = 0; i < max_ticks && s.tick(); ++i) {
  }
}

}  // namespace

TEST(Session, QueriesAfterExactlyKViolationsInARow) {
  LineEnv env;
  ForwardExpert expert;
  // Episode 2 (the first robot episode): violation, ok, violation, violation -> query at decision 4.
  ScriptedMethod method({true, false, true, true});
  DaggerConfig c = small_config();
  c.final_demos = 2;
  DaggerSession s(env, expert, method, c, no_training());
  Recorder rec;
  s.add_observer(rec.fn());
  run_to_end(s);

  std::vector<SessionEvent> decisions;
  for (const auto& e : rec.events)
    if (e.kind == EventKind::kDecision) decisions.push_back(e);
  ASSERT_EQ(decisions.size(), 4u);
  EXPECT_EQ(decisions[0].run, 1);
  EXPECT_EQ(decisions[1].run, 0);  // the run was interrupted
  EXPECT_EQ(decisions[2].run, 1);  // K - 1: no query yet
  EXPECT_EQ(decisions[3].run, 2);
  EXPECT_EQ(rec.count(EventKind::kQuery), 1);
  // The query comes right after the K-th violating decision, then the takeover, at step 6 (3 chunks of 2).
  for (size_t i = 0; i + 2 < rec.events.size(); ++i) {
    if (rec.events[i].kind == EventKind::kQuery) {
      EXPECT_EQ(rec.events[i - 1].kind, EventKind::kDecision);
      EXPECT_EQ(rec.events[i + 1].kind, EventKind::kTakeover);
      EXPECT_EQ(rec.events[i + 1].control, Control::kExpertQuery);
      EXPECT_EQ(rec.events[i].step, 6);
    }
  }
  EXPECT_EQ(s.interventions(), 1);
  EXPECT_TRUE(s.done());
}

TEST(Session, GateRunResetsEachEpisode) {
  LineEnv env;
  ForwardExpert expert;
  // Episode 2 ends with one violation pending (the robot reaches the goal); episode 3's first
  // violation must not complete a K = 2 run.
  std::deque<bool> v(4, false);
  v.push_back(true);   // 5th and last decision of episode 2 (x = 10 after 5 chunks of 2)
  v.push_back(true);   // first decision of episode 3
  v.push_back(false);
  ScriptedMethod method(v);
  DaggerConfig c = small_config();
  c.final_demos = 2;
  c.time_limit = 40;
  DaggerSession s(env, expert, method, c, no_training());
  Recorder rec;
  s.add_observer(rec.fn());
  for (int i = 0; i < 200 && !(s.episode() == 4 && !s.in_episode()); ++i) s.tick();
  EXPECT_EQ(rec.count(EventKind::kDecision), 5 + 5 + 5);  // episodes 2, 3 and 4 ran to the goal
  EXPECT_EQ(rec.count(EventKind::kQuery), 0);
}

TEST(Session, TimeLimitHandsOverToTheExpert) {
  LineEnv env;
  ForwardExpert expert;
  ScriptedMethod method({}, /*speed=*/0.f);  // never violates, never moves
  DaggerConfig c = small_config();
  c.final_demos = 2;
  DaggerSession s(env, expert, method, c, no_training());
  Recorder rec;
  s.add_observer(rec.fn());
  run_to_end(s);
  ASSERT_EQ(rec.count(EventKind::kTimeout), 1);
  for (size_t i = 0; i + 1 < rec.events.size(); ++i) {
    if (rec.events[i].kind == EventKind::kTimeout) {
      EXPECT_EQ(rec.events[i].step, c.time_limit);
      EXPECT_EQ(rec.events[i + 1].kind, EventKind::kTakeover);
      EXPECT_EQ(rec.events[i + 1].control, Control::kExpertTimeout);
    }
  }
  // The expert finished the task after the robot's time limit.
  bool succeeded = false;
  for (const auto& e : rec.events)
    if (e.kind == EventKind::kEpisodeEnd && e.control == Control::kExpertTimeout) succeeded = e.success;
  EXPECT_TRUE(succeeded);
  EXPECT_EQ(s.interventions(), 1);
}

TEST(Session, UpdatesAfterEveryNdInterventionsAndStopsAtNf) {
  LineEnv env;
  ForwardExpert expert;
  std::deque<bool> always(1000, true);
  ScriptedMethod method(always);
  DaggerConfig c = small_config();
  c.initial_demos = 2;
  c.final_demos = 7;
  c.demos_per_update = 2;
  c.patience = 1;
  const std::string path = (std::filesystem::temp_directory_path() / "dd_session_test.hdf5").string();
  std::filesystem::remove(path);
  DatasetWriter writer(path, "{}");
  DaggerSession s(env, expert, method, c, no_training(), &writer);
  Recorder rec;
  s.add_observer(rec.fn());
  run_to_end(s);
  EXPECT_TRUE(s.done());
  EXPECT_EQ(s.expert_demos(), 7);
  EXPECT_EQ(s.interventions(), 5);
  // Initial update on 2 demos; after interventions 2 and 4 (4 and 6 demos); a last one on all 7.
  EXPECT_EQ(method.update_sizes, (std::vector<int>{2, 4, 6, 7}));
  EXPECT_EQ(rec.count(EventKind::kUpdateFinished), 4);
  EXPECT_EQ(rec.events.back().kind, EventKind::kDone);
  EXPECT_FALSE(s.tick());
  // Every expert episode reached the data set, with the intervention flag on the expert's steps.
  const auto eps = read_dataset(path);
  ASSERT_EQ(eps.size(), 7u);
  EXPECT_EQ(eps[0].source, "expert");
  EXPECT_EQ(eps[2].source, "intervention");
  for (uint8_t f : eps[2].intervention) EXPECT_EQ(f, 1);  // K = 1 and a violation at the first decision
  std::filesystem::remove(path);
}

// Every recorded step says who acted: the expert's demonstrations, then the robot until its query,
// then the scripted expert answering it; the label agrees with the intervention flag.
TEST(Session, RecordsWhoActedAtEveryStep) {
  LineEnv env;
  ForwardExpert expert;
  ScriptedMethod method({false, true});  // the robot's second decision violates (K = 1)
  DaggerConfig c = small_config();
  c.initial_demos = 1;
  c.final_demos = 2;
  c.patience = 1;
  const std::string path = (std::filesystem::temp_directory_path() / "dd_session_actor.hdf5").string();
  std::filesystem::remove(path);
  DatasetWriter writer(path, "{}");
  DaggerSession s(env, expert, method, c, no_training(), &writer);
  run_to_end(s);
  const auto eps = read_dataset(path);
  ASSERT_EQ(eps.size(), 2u);
  for (uint8_t a : eps[0].actor) EXPECT_STREQ(kActorLabels[a], "expert_demo");
  const RecordedEpisode& corrected = eps[1];
  ASSERT_EQ(corrected.actor.size(), static_cast<size_t>(corrected.steps()));
  EXPECT_STREQ(kActorLabels[corrected.actor.front()], "robot");
  EXPECT_STREQ(kActorLabels[corrected.actor.back()], "expert_query");
  size_t robot_steps = 0;
  for (size_t t = 0; t < corrected.actor.size(); ++t) {
    EXPECT_EQ(corrected.intervention[t], corrected.actor[t] == 0 ? 0 : 1) << "step " << t;
    robot_steps += corrected.actor[t] == 0;
    if (t > 0) {
      EXPECT_GE(corrected.actor[t], corrected.actor[t - 1]) << "the robot acts first, then the expert";
    }
  }
  EXPECT_GT(robot_steps, 0u);
  std::filesystem::remove(path);

  // The operator answering the query instead of the script: those steps are the operator's.
  LineEnv env2;
  ForwardExpert expert2;
  ScriptedMethod method2({false, true});
  DatasetWriter writer2(path, "{}");
  DaggerSession s2(env2, expert2, method2, c, no_training(), &writer2);
  EXPECT_FALSE(s2.operator_answers_query());  // no query yet
  bool answered = false;
  s2.add_observer([&](const SessionEvent& e) {
    if (e.kind == EventKind::kTakeover && e.control == Control::kExpertQuery) {
      EXPECT_EQ(s2.actor(), Control::kExpertQuery);
      answered = s2.operator_answers_query();
      // control stays the query's; the one acting, shown and recorded, is the operator
      EXPECT_EQ(s2.control(), Control::kExpertQuery);
      EXPECT_EQ(s2.actor(), Control::kOperator);
    }
  });
  run_to_end(s2);
  EXPECT_TRUE(answered);
  const auto eps2 = read_dataset(path);
  ASSERT_EQ(eps2.size(), 2u);
  EXPECT_STREQ(kActorLabels[eps2[1].actor.front()], "robot");
  EXPECT_STREQ(kActorLabels[eps2[1].actor.back()], "operator");
  std::filesystem::remove(path);
}

TEST(Session, EventsComeInOrder) {
  LineEnv env;
  ForwardExpert expert;
  ScriptedMethod method({true, true});
  DaggerConfig c = small_config();
  c.final_demos = 2;
  DaggerSession s(env, expert, method, c, no_training());
  Recorder rec;
  s.add_observer(rec.fn());
  run_to_end(s);
  const std::vector<EventKind> expected_start{EventKind::kEpisodeStart, EventKind::kEpisodeEnd, EventKind::kUpdateStarted,
                                              EventKind::kUpdateFinished, EventKind::kEpisodeStart, EventKind::kDecision,
                                              EventKind::kDecision, EventKind::kQuery, EventKind::kTakeover, EventKind::kEpisodeEnd,
                                              EventKind::kUpdateStarted, EventKind::kUpdateFinished, EventKind::kDone};
  EXPECT_EQ(rec.kinds(), expected_start);
}

TEST(Session, BcDemonstratesNfEpisodesAndTrainsOnce) {
  LineEnv env;
  ForwardExpert expert;
  ScriptedMethod method({}, 1.f, /*gated=*/false);
  DaggerConfig c = small_config();
  c.final_demos = 4;
  DaggerSession s(env, expert, method, c, no_training());
  run_to_end(s);
  EXPECT_EQ(method.update_sizes, (std::vector<int>{4}));
  EXPECT_EQ(s.interventions(), 0);
}

// A "+noise" expert (DART): the session records the expert's own actions and executes them with the
// noise, as `collect` does; without noise the line is walked a step a time.
TEST(Session, AnExpertWithExecutionNoiseIsRecordedCleanAndExecutedNoisy) {
  auto demonstrations = [](float sigma) {
    LineEnv env;
    ForwardExpert expert;
    if (sigma > 0) expert.execution_noise = Vec::Constant(1, sigma);
    ScriptedMethod method({}, 1.f, /*gated=*/false);
    DaggerConfig c = small_config();
    c.final_demos = 2;
    c.time_limit = 40;
    DaggerSession s(env, expert, method, c, no_training());
    run_to_end(s);
    return std::make_pair(s.expert_data(), s.episode_seed());
  };
  for (float sigma : {0.f, 0.5f}) {
    const std::vector<Episode> eps = demonstrations(sigma).first;
    ASSERT_EQ(eps.size(), 2u);
    int short_steps = 0;
    for (const Episode& e : eps) {
      EXPECT_TRUE((e.actions.array() == 1.f).all()) << "a recorded action is not the expert's own";
      for (Eigen::Index t = 1; t < e.obs.rows(); ++t) short_steps += e.obs(t, 0) - e.obs(t - 1, 0) < 0.999f;
    }
    if (sigma == 0)
      EXPECT_EQ(short_steps, 0);
    else
      EXPECT_GT(short_steps, 5) << "the noise was not executed";  // about half the steps draw negative noise
  }
  // `collect` (expert_episode) draws the same noise for the same episode seed: the session's last
  // demonstration is the one collect records with that seed.
  const auto [eps, last_seed] = demonstrations(0.5f);
  LineEnv env;
  ForwardExpert expert;
  expert.execution_noise = Vec::Constant(1, 0.5f);
  const RecordedEpisode collected = expert_episode(env, expert, last_seed);
  EXPECT_TRUE(collected.obs.isApprox(eps.back().obs)) << "collect and the session draw different noise";
}

TEST(Session, StopsAtMaxEpisodesWhenTheRobotNeverNeedsHelp) {
  LineEnv env;
  ForwardExpert expert;
  ScriptedMethod method({});  // never violates, always reaches the goal
  DaggerConfig c = small_config();
  c.final_demos = 5;
  c.max_episodes = 6;
  DaggerSession s(env, expert, method, c, no_training());
  Recorder rec;
  s.add_observer(rec.fn());
  run_to_end(s);
  EXPECT_TRUE(s.done());
  EXPECT_EQ(s.episode(), 6);
  EXPECT_EQ(s.expert_demos(), 1);
  EXPECT_EQ(method.update_sizes, (std::vector<int>{1}));  // no needless retraining on the same data
  EXPECT_EQ(rec.events.back().kind, EventKind::kDone);
}

TEST(Session, MaxEpisodesTriggersALastUpdateOnNewData) {
  LineEnv env;
  ForwardExpert expert;
  std::deque<bool> v(5, false);  // episode 2: the robot succeeds
  v.push_back(true);             // episode 3: asks at once (K = 1)
  ScriptedMethod method(v);
  DaggerConfig c = small_config();
  c.final_demos = 10;
  c.demos_per_update = 4;
  c.patience = 1;
  c.max_episodes = 3;
  DaggerSession s(env, expert, method, c, no_training());
  run_to_end(s);
  EXPECT_TRUE(s.done());
  EXPECT_EQ(s.interventions(), 1);
  EXPECT_EQ(method.update_sizes, (std::vector<int>{1, 2}));
}

TEST(Session, OperatorTakeoverAndHandBackRecordOnlyTheOperatorSteps) {
  LineEnv env;
  ForwardExpert expert;
  ScriptedMethod method({}, /*speed=*/0.25f);  // never asks, moves slowly
  DaggerConfig c = small_config();
  c.final_demos = 2;
  c.time_limit = 100;
  DaggerSession s(env, expert, method, c, no_training());
  Recorder rec;
  s.add_observer(rec.fn());
  EXPECT_FALSE(s.take_over());  // nothing to take over before an episode
  while (s.updates() == 0) s.tick();  // the demonstration and the first update
  EXPECT_FALSE(s.hand_back());        // nothing to hand back between episodes
  for (int i = 0; i < 4; ++i) s.tick();
  ASSERT_EQ(s.control(), Control::kRobot);
  EXPECT_FALSE(s.hand_back());        // the robot is already in control
  ASSERT_TRUE(s.take_over());
  EXPECT_EQ(s.control(), Control::kOperator);
  EXPECT_FALSE(s.take_over());        // already taken over
  for (int i = 0; i < 3; ++i) s.tick();  // three operator steps (the expert's forward action)
  ASSERT_TRUE(s.hand_back());
  EXPECT_EQ(s.control(), Control::kRobot);
  EXPECT_TRUE(s.expert_acted());
  while (s.in_episode()) s.tick();  // the robot finishes the episode
  EXPECT_EQ(s.interventions(), 1);
  ASSERT_EQ(s.expert_data().size(), 2u);
  EXPECT_EQ(s.expert_data().back().obs.rows(), 3);  // only the operator's steps are training data
  EXPECT_EQ(rec.count(EventKind::kHandBack), 1);
  bool operator_takeover = false;
  for (const auto& e : rec.events) operator_takeover |= e.kind == EventKind::kTakeover && e.control == Control::kOperator;
  EXPECT_TRUE(operator_takeover);
}

TEST(Session, EndingAnEpisodeEarlyKeepsItsExpertSteps) {
  LineEnv env;
  ForwardExpert expert;
  ScriptedMethod method({});
  DaggerConfig c = small_config();
  DaggerSession s(env, expert, method, c, no_training());
  for (int i = 0; i < 4; ++i) s.tick();  // four steps of the first demonstration
  ASSERT_TRUE(s.in_episode());
  s.end_episode_now();
  EXPECT_FALSE(s.in_episode());
  ASSERT_EQ(s.expert_data().size(), 1u);
  EXPECT_EQ(s.expert_data()[0].obs.rows(), 4);
  s.end_episode_now();  // between episodes: nothing happens
  EXPECT_EQ(s.expert_data().size(), 1u);
}

TEST(Session, DecisionsMadeElsewhereGiveTheSameRun) {
  // the console computes decisions on a worker thread and hands them in; the run must not change
  auto run = [](bool provide) {
    LineEnv env;
    ForwardExpert expert;
    ScriptedMethod method({false, true, true, false, true, false, false, true, true}, 0.5f);
    DaggerConfig c = small_config();
    DaggerSession s(env, expert, method, c, no_training());
    Recorder rec;
    s.add_observer(rec.fn());
    for (int i = 0; i < 10000 && !s.done(); ++i) {
      if (provide && s.prepare() && s.decision_due()) {
        const uint64_t seed = s.next_decision_seed();
        s.provide_decision(method.decide(env.observation(), seed), 0.0);
      }
      s.tick();
    }
    return rec;
  };
  const Recorder inline_run = run(false), provided_run = run(true);
  EXPECT_EQ(inline_run.kinds(), provided_run.kinds());
  EXPECT_GT(inline_run.count(EventKind::kQuery), 0);
  ASSERT_EQ(inline_run.events.size(), provided_run.events.size());
  for (size_t i = 0; i < inline_run.events.size(); ++i) {
    EXPECT_EQ(inline_run.events[i].step, provided_run.events[i].step);
    EXPECT_EQ(inline_run.events[i].score, provided_run.events[i].score);
  }
}

TEST(Session, RejectsBadSchedules) {
  LineEnv env;
  ForwardExpert expert;
  ScriptedMethod method({});
  DaggerConfig c = small_config();
  c.final_demos = 0;
  EXPECT_THROW(DaggerSession(env, expert, method, c, no_training()), Error);
}

}  // namespace dd

namespace dd {

TEST(Session, AFailedExpertEpisodeIsRecordedButNotTrainedOnOrCounted) {
  LineEnv env;
  FailingExpert expert({2});  // the second demonstration stands still and times out
  ScriptedMethod method({});
  DaggerConfig c = small_config();
  c.initial_demos = 2;
  c.final_demos = 2;
  const std::string path = (std::filesystem::temp_directory_path() / "dd_session_failed_expert.hdf5").string();
  std::filesystem::remove(path);
  {
    DatasetWriter writer(path, R"({"env_name": "line"})");
    DaggerSession s(env, expert, method, c, no_training(), &writer);
    run_to_end(s);
    EXPECT_EQ(s.expert_failures(), 1);
    EXPECT_EQ(s.expert_demos(), 2);                  // the failure did not count toward N_i / N_f
    ASSERT_EQ(method.update_sizes.size(), 1u);
    EXPECT_EQ(method.update_sizes[0], 2);            // nor reach training
    EXPECT_EQ(s.episode(), 3);
  }
  const auto episodes = read_dataset(path);
  ASSERT_EQ(episodes.size(), 3u);                    // but it is in the data set, flagged
  EXPECT_TRUE(episodes[0].success);
  EXPECT_FALSE(episodes[1].success);
  EXPECT_TRUE(episodes[2].success);
  std::filesystem::remove(path);
}

// Moves forward, but gives up once x passes `at` in the episodes listed (by their count of resets).
class GivingUpExpert : public FailingExpert {
 public:
  GivingUpExpert(std::vector<int> giving_up, float at) : FailingExpert({}), giving_up_(std::move(giving_up)), at_(at) {}
  void reset(uint64_t seed) override {
    FailingExpert::reset(seed);
    ++episode_;
  }
  bool gave_up(const Env& env) const override {
    return std::find(giving_up_.begin(), giving_up_.end(), episode_) != giving_up_.end() && env.observation()[0] >= at_;
  }

 private:
  std::vector<int> giving_up_;
  float at_;
  int episode_ = 0;
};

TEST(Session, AnExpertThatGivesUpEndsItsEpisodeAtOnceAsAFailure) {
  LineEnv env;  // goal at 10, 50 steps
  GivingUpExpert expert({2}, 3.0f);  // the second demonstration gives up at x = 3
  ScriptedMethod method({});
  DaggerConfig c = small_config();
  c.initial_demos = 2;
  c.final_demos = 2;
  Recorder rec;
  DaggerSession s(env, expert, method, c, no_training());
  s.add_observer(rec.fn());
  run_to_end(s);
  EXPECT_EQ(s.expert_failures(), 1);
  EXPECT_EQ(s.expert_demos(), 2);  // not a demonstration
  ASSERT_EQ(method.update_sizes.size(), 1u);
  EXPECT_EQ(method.update_sizes[0], 2);  // nor trained on
  std::vector<SessionEvent> ends;
  for (const SessionEvent& e : rec.events)
    if (e.kind == EventKind::kEpisodeEnd) ends.push_back(e);
  ASSERT_EQ(ends.size(), 3u);
  EXPECT_TRUE(ends[0].success);
  EXPECT_FALSE(ends[0].gave_up);
  EXPECT_FALSE(ends[1].success);
  EXPECT_TRUE(ends[1].gave_up);
  EXPECT_EQ(ends[1].step, 3);  // three steps forward, then it gave up: not the 50-step limit
  EXPECT_TRUE(ends[2].success);
  EXPECT_FALSE(ends[2].gave_up);
}

TEST(Session, TheRobotsPartOfAnInterventionIsRobotDataEndingInFailure) {
  LineEnv env;
  ForwardExpert expert;
  ScriptedMethod method({true, true});  // the first robot episode asks after 2 decisions (4 steps)
  DaggerConfig c = small_config();
  c.final_demos = 2;
  DaggerSession s(env, expert, method, c, no_training());
  run_to_end(s);
  ASSERT_EQ(s.interventions(), 1);
  ASSERT_EQ(method.last_robot.size(), 1u);
  const RecordedEpisode& part = method.last_robot[0];
  EXPECT_EQ(part.steps(), 2);  // the query came at the 2nd decision, after the first chunk of T_a = 2 steps
  EXPECT_FALSE(part.success);
  EXPECT_EQ(part.source, "robot");
}

TEST(Session, GatingEveryStepScoresEachStepButExecutesWholeChunks) {
  LineEnv env;
  ForwardExpert expert;
  ScriptedMethod method(std::deque<bool>(200, false));
  DaggerConfig c = small_config();
  c.final_demos = 2;
  c.action_steps = 4;
  c.gate_every = GateCadence::kStep;
  DaggerSession s(env, expert, method, c, no_training());
  Recorder rec;
  s.add_observer(rec.fn());
  while (s.episode() < 2 || s.in_episode()) s.tick();  // the first robot episode: 10 steps to the goal
  EXPECT_EQ(rec.count(EventKind::kDecision), 10);   // one scored decision per robot step
  EXPECT_EQ(env.steps(), 10);

  // K counts steps: two violations in a row are two steps.
  ScriptedMethod asking({false, true, true});
  LineEnv env2;
  DaggerSession s2(env2, expert, asking, c, no_training());
  Recorder rec2;
  s2.add_observer(rec2.fn());
  run_to_end(s2);
  ASSERT_EQ(rec2.count(EventKind::kQuery), 1);
  for (const auto& e : rec2.events) {
    if (e.kind == EventKind::kQuery) {
      EXPECT_EQ(e.step, 2);  // after the 3rd decision, at the 3rd step
    }
  }
}

}  // namespace dd
