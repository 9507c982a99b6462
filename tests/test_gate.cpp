// Quantile calibration and the K-in-a-row query rule on hand-made sequences.
#include <gtest/gtest.h>

#include <cmath>

#include "core/config.h"
#include "core/gate.h"

namespace dd {

TEST(Quantile, IsSortedElementAtFloorNAlpha) {
  std::vector<float> v{5, 1, 4, 2, 3, 9, 8, 7, 6, 10};  // sorted: 1..10
  EXPECT_EQ(quantile(v, 0.0), 1.f);
  EXPECT_EQ(quantile(v, 0.5), 6.f);   // sorted[5]
  EXPECT_EQ(quantile(v, 0.99), 10.f); // sorted[9]
  EXPECT_EQ(quantile(v, 0.9), 10.f);  // sorted[9]
  EXPECT_EQ(quantile(v, 0.85), 9.f);  // sorted[8]
  EXPECT_EQ(quantile(v, 1.0), 10.f);  // clamped to the last
}

TEST(Quantile, RejectsBadInput) {
  EXPECT_THROW(quantile({}, 0.5), Error);
  EXPECT_THROW(quantile({1, 2}, 1.5), Error);
  EXPECT_THROW(quantile({1, NAN}, 0.5), Error);
}

TEST(QueryGate, QueriesAfterExactlyKViolationsInARow) {
  QueryGate gate(1.0f, 3);
  EXPECT_FALSE(gate.observe(2.0f).query);
  EXPECT_FALSE(gate.observe(2.0f).query);
  const GateDecision d = gate.observe(2.0f);
  EXPECT_TRUE(d.violation);
  EXPECT_EQ(d.run, 3);
  EXPECT_TRUE(d.query);
}

TEST(QueryGate, NoQueryAfterKMinusOneOrAnInterruptedRun) {
  QueryGate gate(1.0f, 3);
  EXPECT_FALSE(gate.observe(2.0f).query);
  EXPECT_FALSE(gate.observe(2.0f).query);
  const GateDecision ok = gate.observe(0.5f);  // below the threshold: the run breaks
  EXPECT_FALSE(ok.violation);
  EXPECT_EQ(ok.run, 0);
  EXPECT_FALSE(gate.observe(2.0f).query);
  EXPECT_FALSE(gate.observe(2.0f).query);
  EXPECT_TRUE(gate.observe(2.0f).query);
}

TEST(QueryGate, EqualToThresholdIsNotAViolation) {
  QueryGate gate(1.0f, 1);
  EXPECT_FALSE(gate.observe(1.0f).violation);
  EXPECT_TRUE(gate.observe(1.0001f).query);
}

TEST(QueryGate, ResetsPerEpisode) {
  QueryGate gate(1.0f, 2);
  EXPECT_FALSE(gate.observe(5.0f).query);
  gate.reset();  // new episode
  EXPECT_EQ(gate.run(), 0);
  EXPECT_FALSE(gate.observe(5.0f).query);
  EXPECT_TRUE(gate.observe(5.0f).query);
}

TEST(QueryGate, PatienceOneQueriesOnFirstViolationAndNaNIsAViolation) {
  QueryGate gate(1.0f, 1);
  EXPECT_FALSE(gate.observe(0.1f).query);
  EXPECT_TRUE(gate.observe(NAN).query);
  EXPECT_THROW(QueryGate(1.0f, 0), Error);
}

}  // namespace dd

namespace dd {
TEST(Spearman, MeasuresHowWellOneScoringKeepsTheOthersOrder) {
  const std::vector<float> a{0.1f, 0.5f, 0.2f, 0.9f, 0.3f};
  std::vector<float> squared, reversed;
  for (float v : a) {
    squared.push_back(v * v);  // a monotone transform keeps the order
    reversed.push_back(-v);
  }
  EXPECT_DOUBLE_EQ(spearman(a, squared), 1.0);
  EXPECT_DOUBLE_EQ(spearman(a, reversed), -1.0);
  const std::vector<float> swapped{0.1f, 0.9f, 0.2f, 0.5f, 0.3f};  // the top two ranks swapped
  EXPECT_NEAR(spearman(a, swapped), 0.9, 1e-12);                   // 1 - 6 * 2 / (5 * 24)
  EXPECT_THROW(spearman(a, {1.f, 2.f}), Error);
}
}  // namespace dd
