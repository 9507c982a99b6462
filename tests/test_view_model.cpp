// The console's view model: session events and steps in, the plot's decisions, the timeline rows, the
// path and the counters out.
#include <gtest/gtest.h>

#include "ui/view_model.h"

namespace dd::ui {
namespace {

SessionEvent event(EventKind k, int episode, Control c = Control::kRobot) {
  SessionEvent e(k);
  e.episode = episode;
  e.control = c;
  return e;
}

SessionEvent decision(int episode, float score, bool violation) {
  SessionEvent e = event(EventKind::kDecision, episode);
  e.score = score;
  e.threshold = 1;
  e.violation = violation;
  e.inference_s = 0.05;
  return e;
}

TEST(ViewModel, TimelineRowsFollowEpisodesAndWhoActed) {
  ViewModel vm;
  vm.on_event(event(EventKind::kEpisodeStart, 1), false);
  vm.on_step(1, Control::kRobot, Eigen::Vector2d(0, 0));
  vm.on_step(1, Control::kRobot, Eigen::Vector2d(0.1, 0));
  vm.on_event(event(EventKind::kTakeover, 1, Control::kOperator), true);
  vm.on_step(1, Control::kOperator, Eigen::Vector2d(0.2, 0));
  vm.on_step(2, Control::kRobot, Eigen::Vector2d(9, 9));  // a step of an episode with no row yet: no row changes
  SessionEvent end = event(EventKind::kEpisodeEnd, 1, Control::kOperator);
  end.success = true;
  vm.on_event(end, true);

  ASSERT_EQ(vm.timelines().size(), 1u);
  const Timeline& row = vm.timelines().front();
  EXPECT_EQ(row.steps, (std::vector<Control>{Control::kRobot, Control::kRobot, Control::kOperator}));
  EXPECT_TRUE(row.ended);
  EXPECT_TRUE(row.success);
  ASSERT_EQ(vm.path().size(), 4u);  // positions are recorded whatever the episode; a new episode clears them
  EXPECT_EQ(vm.last_actor(), Control::kRobot);
  EXPECT_EQ(vm.counts().takeovers, 1);
  EXPECT_EQ(vm.counts().robot_episodes, 0);  // the operator acted: not the robot's alone

  vm.on_event(event(EventKind::kEpisodeStart, 2), false);
  EXPECT_TRUE(vm.path().empty());
  vm.on_step(2, Control::kRobot, std::nullopt);  // a task with no plane: a timeline step, no path
  EXPECT_TRUE(vm.path().empty());
  EXPECT_EQ(vm.timelines().back().steps.size(), 1u);
  for (int e = 3; e < 3 + int(ViewModel::kMaxTimelines); ++e) vm.on_event(event(EventKind::kEpisodeStart, e), false);
  EXPECT_EQ(vm.timelines().size(), ViewModel::kMaxTimelines);
  EXPECT_EQ(vm.timelines().front().episode, 3);  // the oldest rows go
}

TEST(ViewModel, CountsRobotEpisodesQueriesTimeoutsAndAnswers) {
  ViewModel vm;
  SessionEvent won = event(EventKind::kEpisodeEnd, 1);
  won.success = true;
  vm.on_event(won, false);
  vm.on_event(event(EventKind::kEpisodeEnd, 2), false);  // the robot alone, failed
  vm.on_event(won, true);                                 // the robot's control at the end, but the expert acted
  vm.on_event(event(EventKind::kQuery, 3), true);
  vm.on_operator_answer();
  vm.on_event(event(EventKind::kTakeover, 3, Control::kExpertTimeout), true);
  vm.on_event(event(EventKind::kTakeover, 3, Control::kExpertQuery), true);  // the scripted expert: no operator takeover
  EXPECT_EQ(vm.counts().robot_episodes, 2);
  EXPECT_EQ(vm.counts().robot_successes, 1);
  EXPECT_EQ(vm.counts().queries, 1);
  EXPECT_EQ(vm.counts().takeovers, 1);
  EXPECT_EQ(vm.counts().timeouts, 1);

  SessionEvent update = event(EventKind::kUpdateFinished, 3);
  update.report.pairs = 1234;
  update.report.threshold = 0.5f;
  vm.on_event(update, false);
  EXPECT_EQ(vm.last_report().pairs, 1234);
  EXPECT_FLOAT_EQ(vm.last_report().threshold, 0.5f);
}

TEST(ViewModel, KeepsTheNewestDecisionsNumberedOverTheSession) {
  ViewModel vm;
  const int n = static_cast<int>(ViewModel::kMaxDecisions) + 25;
  for (int i = 0; i < n; ++i) vm.on_event(decision(1 + i / 100, float(i), i % 3 == 0), false);
  ASSERT_EQ(vm.decisions().size(), ViewModel::kMaxDecisions);
  EXPECT_EQ(vm.decisions().front().index, 25);
  EXPECT_EQ(vm.decisions().back().index, n - 1);
  EXPECT_FLOAT_EQ(vm.decisions().back().score, float(n - 1));
  EXPECT_EQ(vm.decisions().back().violation, (n - 1) % 3 == 0);
  EXPECT_EQ(vm.decisions().back().episode, 1 + (n - 1) / 100);
  EXPECT_NEAR(vm.last_decision_ms(), 50.0, 1e-9);
}

}  // namespace
}  // namespace dd::ui
