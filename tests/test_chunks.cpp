// Training pairs from episodes, and min-max normalisation.
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "core/chunks.h"
#include "core/config.h"
#include "core/normalizer.h"

namespace dd {

TEST(ChunkDataset, OnePairPerStepPaddedWithTheLastAction) {
  Episode ep;
  ep.obs = Mat(3, 1);
  ep.obs << 10, 11, 12;
  ep.actions = Mat(3, 2);
  ep.actions << 1, -1, 2, -2, 3, -3;
  const ChunkDataset d = ChunkDataset::from_episodes({ep}, 4);
  ASSERT_EQ(d.size(), 3);
  EXPECT_EQ(d.obs(1, 0), 11);
  Mat expected(4, 2);
  expected << 2, -2, 3, -3, 3, -3, 3, -3;  // from step 1: actions 1, 2, then padding
  EXPECT_EQ(d.chunk(1), expected);
  EXPECT_EQ(d.chunk(2).row(0), ep.actions.row(2));
  EXPECT_EQ(d.action_rows().rows(), 12);
}

TEST(ChunkDataset, RejectsInconsistentEpisodes) {
  Episode a{Mat::Zero(3, 2), Mat::Zero(3, 1)};
  Episode b{Mat::Zero(3, 2), Mat::Zero(2, 1)};
  EXPECT_THROW(ChunkDataset::from_episodes({a, b}, 4), Error);
  Episode c{Mat::Zero(3, 2), Mat::Zero(3, 1)};
  c.actions(1, 0) = NAN;
  EXPECT_THROW(ChunkDataset::from_episodes({c}, 4), Error);
  EXPECT_THROW(ChunkDataset::from_episodes({}, 4), Error);
}

TEST(ChunkDataset, SubsetDrawsDistinctPairsReproducibly) {
  Episode ep{Mat(20, 1), Mat(20, 1)};
  for (int i = 0; i < 20; ++i) ep.obs(i, 0) = ep.actions(i, 0) = static_cast<float>(i);
  const ChunkDataset d = ChunkDataset::from_episodes({ep}, 2);
  const ChunkDataset s = d.subset(7, 3);
  ASSERT_EQ(s.size(), 7);
  std::set<float> seen;
  for (int i = 0; i < 7; ++i) {
    seen.insert(s.obs(i, 0));
    EXPECT_EQ(s.chunks(i, 0), s.obs(i, 0));  // pairs stay together
  }
  EXPECT_EQ(seen.size(), 7u);
  EXPECT_EQ(d.subset(7, 3).obs, s.obs);
  EXPECT_EQ(d.subset(0, 3).size(), 20);
  EXPECT_EQ(d.subset(50, 3).size(), 20);
}

TEST(Normalizer, MapsRangeToMinusOneOneAndBack) {
  Mat x(3, 2);
  x << 0, 5, 10, 5, 5, 5;  // dim 1 is constant
  const Normalizer n = Normalizer::fit(x);
  const Mat y = n.normalize(x);
  EXPECT_FLOAT_EQ(y(0, 0), -1);
  EXPECT_FLOAT_EQ(y(1, 0), 1);
  EXPECT_FLOAT_EQ(y(2, 0), 0);
  for (int i = 0; i < 3; ++i) EXPECT_FLOAT_EQ(y(i, 1), 0);  // constant -> 0
  EXPECT_TRUE(n.unnormalize(y).isApprox(x, 1e-6f));
}

TEST(Normalizer, PinnedConstantsUnnormaliseToTheConstantWhateverTheNetworkSays) {
  Mat x(3, 2);
  x << 0, 0.7f, 10, 0.7f, 5, 0.7f;  // dim 1 is constant (an action axis the expert never moves)
  const Normalizer pin = Normalizer::fit(x, Normalizer::Constants::kPin);
  EXPECT_NEAR(pin.normalize(x)(1, 1), 0.0f, 1e-2f);
  Mat out(2, 2);
  out << -1, -1, 1, 1;  // the network's extremes
  const Mat raw = pin.unnormalize(out);
  EXPECT_NEAR(raw(0, 1), 0.7f, 1e-4f);
  EXPECT_NEAR(raw(1, 1), 0.7f, 1e-4f);
  EXPECT_NEAR(raw(0, 0), 0.0f, 1e-5f);  // varying dimensions are unchanged
  EXPECT_NEAR(raw(1, 0), 10.0f, 1e-5f);
  // observations pass a constant through unamplified: a run-time change of 0.1 stays 0.1
  const Normalizer pass = Normalizer::fit(x);
  Mat moved = x;
  moved(0, 1) += 0.1f;
  EXPECT_NEAR(pass.normalize(moved)(0, 1), 0.1f, 1e-5f);
}

TEST(Normalizer, RejectsEmptyAndNonFinite) {
  EXPECT_THROW(Normalizer::fit(Mat(0, 2)), Error);
  Mat x = Mat::Zero(2, 2);
  x(0, 0) = INFINITY;
  EXPECT_THROW(Normalizer::fit(x), Error);
}

}  // namespace dd
