// Learning behaviour of the diffusion policy on a synthetic bimodal data set: the loss falls, both
// modes are sampled, and the expected loss separates training pairs from out-of-distribution ones.
// Small network, fixed seeds, a short budget: properties are checked, never exact floats.
#include <gtest/gtest.h>

#include <cmath>
#include <algorithm>
#include <cstdio>
#include <memory>
#include <numeric>
#include <random>

#include "core/chunks.h"
#include "core/gate.h"
#include "core/policy.h"
#include "core/synthetic.h"
#include "core/trainer.h"
#include "tests/fakes.h"

namespace dd {
namespace {

class BimodalPolicy : public testing::Test {
 protected:
  static void SetUpTestSuite() {
    data_ = new ChunkDataset(ChunkDataset::from_episodes(bimodal_episodes(80, 12, 2, 2, /*seed=*/7), 8));
    policy_ = new DiffusionPolicy(fakes::tiny_policy(), /*seed=*/3);
    TrainConfig t;
    t.steps = 500;
    t.batch_size = 128;
    t.lr = 1e-3;
    t.warmup_steps = 25;
    t.seed = 11;
    stats_ = new TrainStats(train(*policy_, *data_, t));
  }
  static void TearDownTestSuite() {
    delete policy_;
    delete data_;
    delete stats_;
  }
  static DiffusionPolicy* policy_;
  static ChunkDataset* data_;
  static TrainStats* stats_;
};

DiffusionPolicy* BimodalPolicy::policy_ = nullptr;
ChunkDataset* BimodalPolicy::data_ = nullptr;
TrainStats* BimodalPolicy::stats_ = nullptr;

}  // namespace

TEST_F(BimodalPolicy, TrainingLossFalls) {
  ASSERT_EQ(stats_->losses.size(), 500u);
  EXPECT_LT(stats_->last_mean(50), 0.5 * stats_->first_mean(50))
      << "first " << stats_->first_mean(50) << " last " << stats_->last_mean(50);
}

TEST_F(BimodalPolicy, SamplesBothModesAndSeldomBetween) {
  const Vec obs = data_->obs.row(0).transpose();
  const Mat many = obs.transpose().replicate(200, 1);
  const std::vector<Mat> chunks = policy_->sample_batch(many, /*seed=*/5);
  int plus = 0, minus = 0, between = 0;
  for (const Mat& c : chunks) {
    const int m = bimodal_mode(c);
    (m > 0 ? plus : m < 0 ? minus : between)++;
  }
  EXPECT_GE(plus, 40) << "plus " << plus << " minus " << minus << " between " << between;
  EXPECT_GE(minus, 40) << "plus " << plus << " minus " << minus << " between " << between;
  EXPECT_LE(between, 20) << "plus " << plus << " minus " << minus << " between " << between;
}

// sample_batch samples many rows in blocks (512 rows) from one generator: every row comes back, the
// first block draws what it draws alone, and a later block continues the stream instead of
// restarting it (the same observation in rows 0 and 512 gets different chunks).
TEST_F(BimodalPolicy, ABatchOfSeveralBlocksComesBackWholeFromOneNoiseStream) {
  const Mat many = data_->obs.row(0).replicate(1100, 1);
  const std::vector<Mat> chunks = policy_->sample_batch(many, /*seed=*/5);
  ASSERT_EQ(chunks.size(), 1100u);
  const std::vector<Mat> first_block = policy_->sample_batch(many.topRows(512), /*seed=*/5);
  for (size_t i = 0; i < first_block.size(); ++i) ASSERT_TRUE((chunks[i].array() == first_block[i].array()).all()) << "row " << i;
  EXPECT_FALSE(chunks[512].isApprox(chunks[0], 1e-6f));
  EXPECT_FALSE(chunks[1024].isApprox(chunks[512], 1e-6f));
  int plus = 0;
  for (size_t i = 512; i < chunks.size(); ++i) plus += bimodal_mode(chunks[i]) > 0;
  EXPECT_GT(plus, 100) << "the later blocks sample both modes too";
  EXPECT_LT(plus, 488) << "the later blocks sample both modes too";
}

TEST_F(BimodalPolicy, ExpectedLossOfTrainingPairsIsBelowOutOfDistribution) {
  int separated = 0;
  const int n = 100;
  for (int i = 0; i < n; ++i) {
    const Vec obs = data_->obs.row(i * 7).transpose();
    const Mat chunk = data_->chunk(i * 7);
    const Mat far = chunk.array() + 3.0f;  // well outside the action range seen in training
    const float in = policy_->expected_loss(obs, chunk, /*seed=*/i);
    const float out = policy_->expected_loss(obs, far, /*seed=*/i);
    separated += in < out;
  }
  EXPECT_GE(separated, 95);
}

TEST_F(BimodalPolicy, ExpectedLossIsSeededAndStable) {
  const Vec obs = data_->obs.row(3).transpose();
  const Mat chunk = data_->chunk(3);
  EXPECT_EQ(policy_->expected_loss(obs, chunk, 1), policy_->expected_loss(obs, chunk, 1));
  // Different noise draws over N_b = 512 give close estimates.
  const float a = policy_->expected_loss(obs, chunk, 1), b = policy_->expected_loss(obs, chunk, 2);
  EXPECT_LT(std::abs(a - b), 0.5f * std::max(a, b));
}

// The loss split by timestep averages back to the expected loss, and the scores in other spaces are
// the conversions the targets imply: for a v-trained network, per timestep, epsilon-space loss =
// alpha_bar_t * v-loss and sample-space loss = (1 - alpha_bar_t) * v-loss, so the two ratios add up
// to 1 and the epsilon ratio falls as the noise grows.
TEST_F(BimodalPolicy, LossByTimestepAveragesToTheExpectedLossAndConvertsBetweenSpaces) {
  ASSERT_EQ(policy_->config().scheduler.prediction, PredictionType::kVelocity);
  const Vec obs = data_->obs.row(5).transpose();
  const Mat chunk = data_->chunk(5);
  const int T = policy_->config().scheduler.num_train_timesteps;
  const std::vector<float> v = policy_->loss_by_timestep(obs, chunk, 7, 8 * T);
  ASSERT_EQ(v.size(), static_cast<size_t>(T));
  EXPECT_NEAR(std::accumulate(v.begin(), v.end(), 0.0) / T, policy_->expected_loss(obs, chunk, 7, 8 * T), 1e-5);
  auto in_space = [&](ScoreSpace s) {
    policy_->set_score_space(s);
    std::vector<float> l = policy_->loss_by_timestep(obs, chunk, 7, 8 * T);
    policy_->set_score_space(ScoreSpace::kTarget);
    return l;
  };
  const std::vector<float> eps = in_space(ScoreSpace::kEpsilon), x0 = in_space(ScoreSpace::kSample), vv = in_space(ScoreSpace::kVelocity);
  for (int t = 0; t < T; ++t) {
    const size_t i = static_cast<size_t>(t);
    EXPECT_NEAR(vv[i], v[i], 1e-4 * v[i] + 1e-7) << "t " << t;
    EXPECT_NEAR(eps[i] / v[i] + x0[i] / v[i], 1.0, 1e-3) << "t " << t;
    if (t > 0) {
      EXPECT_LT(eps[i] / v[i], eps[i - 1] / v[i - 1]) << "alpha_bar falls with t";
    }
  }
  // every space from one pass: the same numbers as one space at a time
  const std::vector<std::vector<float>> all =
      policy_->loss_by_timestep(obs, chunk, 7, 8 * T, {ScoreSpace::kEpsilon, ScoreSpace::kSample, ScoreSpace::kTarget});
  ASSERT_EQ(all.size(), 3u);
  for (int t = 0; t < T; ++t) {
    const size_t i = static_cast<size_t>(t);
    EXPECT_FLOAT_EQ(all[0][i], eps[i]) << "t " << t;
    EXPECT_FLOAT_EQ(all[1][i], x0[i]) << "t " << t;
    EXPECT_FLOAT_EQ(all[2][i], v[i]) << "t " << t;
  }
  EXPECT_THROW(policy_->loss_by_timestep(obs, chunk, 7, T + 1), Error);
}

// The score restricted to the low-noise timesteps [0, K): it estimates the mean of the per-timestep
// losses below K; K = T_d is the full score, number for number; K outside [0, T_d] is refused.
TEST_F(BimodalPolicy, TheScoreRestrictedToLowNoiseTimestepsAveragesThoseTimesteps) {
  const Vec obs = data_->obs.row(5).transpose();
  const Mat chunk = data_->chunk(5);
  const int T = policy_->config().scheduler.num_train_timesteps;
  ASSERT_GE(T, 8);
  const float full = policy_->expected_loss(obs, chunk, 7, 8 * T);
  policy_->set_score_timesteps(T);
  EXPECT_FLOAT_EQ(policy_->expected_loss(obs, chunk, 7, 8 * T), full);
  EXPECT_EQ(policy_->score_timesteps(), T);

  const std::vector<float> by_t = policy_->loss_by_timestep(obs, chunk, 3, 128 * T);
  const int K = T / 4;
  const double low = std::accumulate(by_t.begin(), by_t.begin() + K, 0.0) / K;
  const double all = std::accumulate(by_t.begin(), by_t.end(), 0.0) / T;
  policy_->set_score_timesteps(K);
  EXPECT_EQ(policy_->score_timesteps(), K);
  const float restricted = policy_->expected_loss(obs, chunk, 11, 512 * K);
  EXPECT_NEAR(restricted, low, 0.1 * low) << "all timesteps: " << all;
  ASSERT_GT(std::abs(all - low), 0.25 * low) << "the check needs low-noise losses unlike the mean of all";
  // the threshold over training pairs uses the same restricted score, screened or not
  ChunkDataset few = *data_;
  few.obs = data_->obs.topRows(24);
  few.chunks = data_->chunks.topRows(24);
  const LossQuantile q = policy_->loss_quantile(few, 0.9, 5, 16 * K, /*screen=*/true);
  EXPECT_TRUE(std::isfinite(q.threshold) && q.threshold > 0);
  policy_->set_score_timesteps(0);
  EXPECT_EQ(policy_->score_timesteps(), T);
  EXPECT_FLOAT_EQ(policy_->expected_loss(obs, chunk, 7, 8 * T), full);
  EXPECT_THROW(policy_->set_score_timesteps(T + 1), Error);
  EXPECT_THROW(policy_->set_score_timesteps(-1), Error);
}

TEST_F(BimodalPolicy, BatchedLossesMatchOneByOne) {
  ChunkDataset few = *data_;
  few.obs = data_->obs.topRows(10);
  few.chunks = data_->chunks.topRows(10);
  const std::vector<float> batched = policy_->expected_losses(few, 4, 64);
  ASSERT_EQ(batched.size(), 10u);
  for (int i = 0; i < 10; ++i) {
    const float single = policy_->expected_loss(few.obs.row(i).transpose(), few.chunk(i), 9, 512);
    EXPECT_NEAR(batched[static_cast<size_t>(i)], single, 0.5f * std::max(single, 0.02f)) << i;
  }
}

TEST_F(BimodalPolicy, CalibratedGateFlagsOutOfDistributionChunks) {
  const std::vector<float> losses = policy_->expected_losses(*data_, /*seed=*/21, 128);
  const float threshold = quantile(losses, 0.99);
  QueryGate gate(threshold, 1);
  int queried_ood = 0, queried_id = 0;
  for (int i = 0; i < 40; ++i) {
    const Vec obs = data_->obs.row(i * 11).transpose();
    gate.reset();
    queried_ood += gate.observe(policy_->expected_loss(obs, Mat(data_->chunk(i * 11).array() - 3.0f), i)).query;
    gate.reset();
    queried_id += gate.observe(policy_->expected_loss(obs, data_->chunk(i * 11), i)).query;
  }
  EXPECT_GE(queried_ood, 38);
  EXPECT_LE(queried_id, 4);
}

TEST_F(BimodalPolicy, ScreenedThresholdIsTheAllRowsOne) {
  // A worst case for screening: 16 values per chunk make single rows' losses heavy-tailed, so many
  // pairs stay candidates (on pushing's 224 values, 78 of 5055 pairs did; see the README).
  constexpr int kRows = 128;
  constexpr double kAlpha = 0.99;
  const ChunkDataset pairs = data_->subset(320, 2);
  std::vector<float> all_rows;
  for (uint64_t seed = 40; seed < 44; ++seed) {
    const LossQuantile q = policy_->loss_quantile(pairs, kAlpha, seed, kRows, /*screen=*/false);
    EXPECT_EQ(q.refined, pairs.size());
    EXPECT_EQ(q.screen_samples, 0);
    all_rows.push_back(q.threshold);
  }
  const auto [lo, hi] = std::minmax_element(all_rows.begin(), all_rows.end());
  // the all-rows threshold varies with the noise drawn; the screened one must fall in that spread
  const float tol = std::max(*hi - *lo, 0.02f * *hi);
  const int above = pairs.size() - static_cast<int>(std::floor(pairs.size() * kAlpha));
  for (uint64_t seed = 50; seed < 54; ++seed) {
    const LossQuantile q = policy_->loss_quantile(pairs, kAlpha, seed, kRows);
    std::printf("screened %.5f (%d of %d refined); all rows %.5f .. %.5f\n", q.threshold, q.refined, q.pairs, *lo, *hi);
    EXPECT_EQ(q.pairs, pairs.size());
    EXPECT_EQ(q.screen_samples, kRows / 4) << "two rows per timestep";
    EXPECT_GE(q.refined, above) << "every pair at or above the quantile is scored in full";
    EXPECT_LT(q.refined, pairs.size()) << "screening left no pair out";
    EXPECT_GE(q.threshold, *lo - tol) << seed;
    EXPECT_LE(q.threshold, *hi + tol) << seed;
  }
}

// Targets at a fixed offset from an observed position, over a wide range of positions: relative to
// the observation they are one value, which the model gets exactly, where the absolute policy has to
// learn the identity map over the whole range.
TEST(RelativeActions, ChunksAreLearnedInTheObservationsFrame) {
  std::vector<Episode> episodes;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(-1, 1);
  for (int e = 0; e < 20; ++e) {
    Episode ep;
    ep.obs.resize(12, 2);
    ep.actions.resize(12, 2);
    const float position = u(rng);  // one per episode
    for (int t = 0; t < 12; ++t) {
      ep.obs.row(t) << position, u(rng);
      ep.actions.row(t) << position + 0.25f, 0.5f * u(rng);  // action 0: the observed position + 0.25
    }
    episodes.push_back(ep);
  }
  const ChunkDataset data = ChunkDataset::from_episodes(episodes, 8);
  TrainConfig t;
  t.steps = 100;
  t.batch_size = 64;
  t.lr = 1e-3;
  t.warmup_steps = 10;
  double error[3] = {0, 0, 0};
  for (int variant : {0, 1, 2}) {  // absolute; relative; relative, normalised per chunk step
    PolicyConfig c = fakes::tiny_policy();
    if (variant > 0) c.relative_actions = {{0, 0}};
    c.action_norm_per_step = variant == 2;
    auto policy = std::make_unique<DiffusionPolicy>(c, 5);
    train(*policy, data, t);
    if (variant == 2) {  // the per-step normaliser (horizon * action_dim values) goes through a checkpoint
      EXPECT_EQ(policy->action_normalizer().dim(), 8 * 2);
      const std::string path = testing::TempDir() + "/relative_per_step.pt";
      policy->save(path);
      policy = DiffusionPolicy::from_checkpoint(path);
      EXPECT_TRUE(policy->config().action_norm_per_step);
    }
    for (int i = 0; i < 10; ++i) {
      const Vec obs = Eigen::Vector2f(-0.9f + 0.2f * i, 0.3f);
      const Mat chunk = policy->sample(obs, 40 + i);
      ASSERT_EQ(chunk.rows(), 8);
      error[variant] += (chunk.col(0).array() - (obs[0] + 0.25f)).abs().mean() / 10;
    }
  }
  EXPECT_LT(error[1], 1e-3) << "every step of a relative chunk is its observation plus the offset";
  EXPECT_LT(error[2], 1e-3) << "the same, normalised per step";
  EXPECT_GT(error[0], 10 * error[1]) << "absolute " << error[0] << " relative " << error[1];
}

TEST_F(BimodalPolicy, DecisionGivesAChunkInRangeAndAFiniteLoss) {
  const Decision d = policy_->decide(data_->obs.row(0).transpose(), 2);
  EXPECT_EQ(d.chunk.rows(), 8);
  EXPECT_EQ(d.chunk.cols(), 2);
  EXPECT_TRUE(std::isfinite(d.loss));
  EXPECT_NE(bimodal_mode(d.chunk), 0);
  EXPECT_THROW(policy_->sample(Vec::Zero(5), 0), Error);  // wrong observation size
}

// The screened gate: the chunk is the plain decision's (the same sampling); a threshold far above
// the chunk's loss is settled by the first eighth of the rows, one far below it takes all of them,
// and in between the verdict is the one all rows give wherever that is not a coin flip.
TEST_F(BimodalPolicy, AScreenedDecisionStopsEarlyOnlyWellBelowTheThreshold) {
  constexpr int kRows = 512;  // T_d 16: screening rows 64, then 128, 256, 512 in all
  int early = 0, full = 0, compared = 0;
  for (int i = 0; i < 24; ++i) {
    const Vec obs = data_->obs.row(i * 13).transpose();
    const uint64_t seed = 100 + static_cast<uint64_t>(i);
    const Decision plain = policy_->decide(obs, seed, kRows);
    EXPECT_EQ(plain.rows, kRows);
    // far above: settled by the first 64 rows
    const Decision above = policy_->decide_screened(obs, seed, kRows, 4 * plain.loss);
    EXPECT_TRUE(above.chunk.isApprox(plain.chunk, 0.f)) << i;
    EXPECT_EQ(above.rows, 64) << i;
    EXPECT_LT(above.loss, 4 * plain.loss);
    // at or below the loss: every row, and a mean over all of them
    const Decision below = policy_->decide_screened(obs, seed, kRows, 0.5f * plain.loss);
    EXPECT_EQ(below.rows, kRows) << i;
    EXPECT_GT(below.loss, 0.5f * plain.loss) << i;
    EXPECT_NEAR(below.loss, plain.loss, 0.25f * plain.loss) << "another draw of the same expectation";
    // thresholds over the range between: the verdict agrees with all rows' except near the
    // threshold, where two draws of 512 rows disagree as well
    for (const float f : {0.8f, 1.1f, 1.3f, 1.6f, 2.0f}) {
      const Decision d = policy_->decide_screened(obs, seed, kRows, f * plain.loss);
      EXPECT_TRUE(d.rows == 64 || d.rows == 128 || d.rows == 256 || d.rows == 512) << d.rows;
      (d.rows < kRows ? early : full)++;
      if (d.rows < kRows) {
        EXPECT_LT(d.loss, f * plain.loss) << "stopped early above the threshold";
      }
      if (f >= 1.3f || f <= 0.8f) {
        ++compared;
        EXPECT_EQ(d.loss > f * plain.loss, plain.loss > f * plain.loss) << i << " at " << f;
      }
    }
  }
  EXPECT_GT(early, 0);
  EXPECT_GT(full, 0);
  EXPECT_GT(compared, 50);
  // no threshold yet (infinite), or too few rows to screen: the plain decision
  const Vec obs = data_->obs.row(5).transpose();
  const Decision plain = policy_->decide(obs, 7, 64);
  const Decision none = policy_->decide_screened(obs, 7, 64, INFINITY);
  EXPECT_EQ(none.loss, plain.loss);
  EXPECT_EQ(none.rows, 64);
  const Decision few = policy_->decide_screened(obs, 7, 64, 1e6f);
  EXPECT_EQ(few.rows, 64) << "an eighth of 64 rows is less than two per timestep: not screened";
  EXPECT_EQ(few.loss, plain.loss);
}

// A decision scored in further spaces from its own rows: its chunk and loss are the plain decision's,
// and each further loss is what the decision gives with the policy scoring in that space (the same
// sample, the same noise), also when the policy scores only the low-noise timesteps.
TEST_F(BimodalPolicy, ADecisionScoresFurtherSpacesFromItsOwnRows) {
  const Vec obs = data_->obs.row(3).transpose();
  for (const int k : {0, 2}) {
    policy_->set_score_timesteps(k);
    const Decision plain = policy_->decide(obs, 11, 64);
    const Decision both = policy_->decide(obs, 11, 64, {ScoreSpace::kEpsilon, ScoreSpace::kSample});
    EXPECT_TRUE(plain.also.empty());
    ASSERT_EQ(both.also.size(), 2u);
    EXPECT_EQ(both.loss, plain.loss) << "k " << k;
    EXPECT_TRUE(both.chunk.isApprox(plain.chunk, 0.f)) << "k " << k;
    policy_->set_score_space(ScoreSpace::kEpsilon);
    const Decision eps = policy_->decide(obs, 11, 64);
    policy_->set_score_space(ScoreSpace::kSample);
    const Decision x0 = policy_->decide(obs, 11, 64);
    policy_->set_score_space(ScoreSpace::kTarget);
    EXPECT_EQ(both.also[0], eps.loss) << "k " << k;
    EXPECT_EQ(both.also[1], x0.loss) << "k " << k;
    EXPECT_NE(both.also[0], both.loss) << "another space scores another number";
  }
  policy_->set_score_timesteps(0);
}

}  // namespace dd
