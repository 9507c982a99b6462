// The evaluation protocol's fairness between methods, with small real networks on synthetic data:
// Thrifty's second pass trains its critic alone, the ensembles act with a member that saw all the
// data, the loss can be scored with either set of weights, failure prediction leaves empty classes
// undefined, and rollouts gate per chunk or per step like the session.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>

#include <sys/wait.h>
#include <unistd.h>

#include "core/critic.h"
#include "core/ensemble.h"
#include "core/evaluation.h"
#include "core/method.h"
#include "core/normalizer.h"
#include "core/policy.h"
#include "core/synthetic.h"
#include "core/gate.h"
#include "core/isolate.h"
#include "core/runtime.h"
#include "core/trainer.h"
#include "tests/fakes.h"

namespace dd {
namespace {

TrainConfig short_training(int steps = 40) {
  TrainConfig t;
  t.steps = steps;
  t.batch_size = 32;
  t.lr = 1e-3;
  t.warmup_steps = 5;
  return t;
}

MethodConfig small_method() {
  MethodConfig m;
  m.members = 3;
  m.loss_samples = 32;
  m.calibration_pairs = 64;
  m.critic.steps = 30;
  m.critic.hidden = 16;
  return m;
}

// Robot data whose episodes fail, so that the critic has something to learn that demonstrations lack.
std::vector<RecordedEpisode> failing_robot_data(const std::vector<Episode>& like) {
  std::vector<RecordedEpisode> out;
  for (int i = 0; i < 4; ++i) {
    RecordedEpisode r;
    r.obs = like[static_cast<size_t>(i)].obs.array() + 0.5f;
    r.actions = -like[static_cast<size_t>(i)].actions;
    r.success = false;
    r.source = "robot";
    out.push_back(r);
  }
  return out;
}

}  // namespace

TEST(Methods, ThriftysRiskRefitLeavesItsPoliciesAlone) {
  const auto episodes = bimodal_episodes(12, 10, 2, 2, /*seed=*/5);
  auto m = make_method("thrifty", fakes::tiny_policy(), small_method(), 1);
  m->update(episodes, {}, short_training());
  const Vec obs = Vec::Constant(2, 0.2f);
  const MethodDecision before = m->decide(obs, 77);
  const double seconds = m->refit_risk(episodes, failing_robot_data(episodes));
  EXPECT_GT(seconds, 0.0);
  const MethodDecision after = m->decide(obs, 77);
  // same members, same seed: the same chunks and spread; only the critic moved
  EXPECT_TRUE(before.chunk.isApprox(after.chunk, 1e-6f));
  EXPECT_FLOAT_EQ(before.score, after.score);
  EXPECT_NE(before.risk_q, after.risk_q);
  // the other methods have no risk to refit
  auto diff = make_method("diff", fakes::tiny_policy(), small_method(), 1);
  EXPECT_EQ(diff->refit_risk(episodes, {}), 0.0);
}

// A resume point with a corrupt member or critic file is an Error naming the file, and the method
// that tried to load it is left as it was: no member, critic, threshold or gamma of the bad state.
TEST(Methods, ARestoreWithABadFileLeavesTheEnsembleAsItWas) {
  namespace fs = std::filesystem;
  const auto episodes = bimodal_episodes(12, 10, 2, 2, /*seed=*/5);
  const std::string dir = (fs::temp_directory_path() / ("dd_restore_" + std::to_string(::getpid()))).string();
  auto saved = make_method("thrifty", fakes::tiny_policy(), small_method(), 1);
  saved->update(episodes, failing_robot_data(episodes), short_training());
  saved->save_state(dir);
  auto target = make_method("thrifty", fakes::tiny_policy(), small_method(), 2);
  target->update(episodes, {}, short_training(20));
  const Vec obs = Vec::Constant(2, 0.2f);
  const MethodDecision before = target->decide(obs, 77);
  const float threshold = target->threshold();
  auto unchanged = [&](const std::string& what) {
    const MethodDecision now = target->decide(obs, 77);
    EXPECT_TRUE(now.chunk.isApprox(before.chunk, 1e-6f)) << what;
    EXPECT_FLOAT_EQ(now.score, before.score) << what;
    EXPECT_FLOAT_EQ(now.risk_q, before.risk_q) << what;
    EXPECT_FLOAT_EQ(target->threshold(), threshold) << what;
  };
  auto message = [&](const std::string& file) {
    try {
      target->load_state(dir);
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("(no error for a bad " + file + ")");
  };
  // the last member's file cut short: the members before it would have loaded one by one
  const std::string member = dir + "/member_2.pt";
  fs::resize_file(member, fs::file_size(member) / 2);
  const std::string bad_member = message(member);
  EXPECT_EQ(bad_member.rfind(member + ": ", 0), 0u) << bad_member;
  unchanged("after a bad member file");
  // good members, a cut-short critic
  saved->save_state(dir);
  const std::string critic = dir + "/critic.pt";
  fs::resize_file(critic, fs::file_size(critic) / 2);
  const std::string bad_critic = message(critic);
  EXPECT_EQ(bad_critic.rfind(critic + ": ", 0), 0u) << bad_critic;
  unchanged("after a bad critic file");
  // and a good state loads whole: the saved method's decisions
  saved->save_state(dir);
  target->load_state(dir);
  const MethodDecision want = saved->decide(obs, 77), got = target->decide(obs, 77);
  EXPECT_TRUE(got.chunk.isApprox(want.chunk, 1e-6f));
  EXPECT_FLOAT_EQ(got.score, want.score);
  EXPECT_FLOAT_EQ(got.risk_q, want.risk_q);
  EXPECT_FLOAT_EQ(target->threshold(), saved->threshold());
  fs::remove_all(dir);
}

TEST(Methods, TheEnsemblesActingMemberIsTrainedOnAllTheData) {
  // Three episodes with disjoint observation ranges: a bootstrap resample usually misses one.
  auto episodes = bimodal_episodes(3, 10, 2, 2, /*seed=*/9);
  for (size_t i = 0; i < episodes.size(); ++i) episodes[i].obs.array() += 3.0f * static_cast<float>(i);
  PolicyEnsemble ensemble(fakes::tiny_policy(), 8, /*seed=*/2);
  ensemble.train(episodes, short_training(2));
  std::vector<Episode> all = episodes;
  const Normalizer full = Normalizer::fit(ChunkDataset::from_episodes(all, 8).obs);
  EXPECT_TRUE(ensemble.member(0).obs_normalizer().scale().isApprox(full.scale()));
  EXPECT_TRUE(ensemble.member(0).obs_normalizer().offset().isApprox(full.offset()));
  int bootstrapped_differently = 0;
  for (int i = 1; i < ensemble.size(); ++i) {
    bootstrapped_differently += !ensemble.member(i).obs_normalizer().scale().isApprox(full.scale());
  }
  EXPECT_GT(bootstrapped_differently, 0);  // resamples: P(all 7 hold the first and the last episode) < 0.004
}

TEST(Methods, TheEnsembleTrainingCacheLoadsWhatTheSameTrainingGave) {
  namespace fs = std::filesystem;
  const auto episodes = bimodal_episodes(6, 10, 2, 2, /*seed=*/4);
  const fs::path dir = fs::temp_directory_path() / ("dd_ensemble_cache_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  struct CacheOff {
    ~CacheOff() { set_ensemble_train_cache(""); }
  } cache_off;
  const Vec obs = Vec::Constant(2, 0.3f);
  auto same_members = [&](const PolicyEnsemble& a, const PolicyEnsemble& b) {
    const auto da = a.decide(obs, 5), db = b.decide(obs, 5);
    return da.chunk.cwiseEqual(db.chunk).all() && da.variance == db.variance;
  };
  auto trained = [&](const std::vector<Episode>& data, int steps = 10, uint64_t seed = 2) {
    auto e = std::make_unique<PolicyEnsemble>(fakes::tiny_policy(), 3, seed);
    e->train(data, short_training(steps));
    return e;
  };

  // what training gives with no cache
  const auto plain = trained(episodes);
  EXPECT_FALSE(plain->last_train_reused());

  set_ensemble_train_cache(dir.string());
  PolicyEnsemble first(fakes::tiny_policy(), 3, 2);
  const auto first_stats = first.train(episodes, short_training(10));
  EXPECT_FALSE(first.last_train_reused());
  EXPECT_GT(first.last_train_seconds(), 0.0);
  EXPECT_TRUE(same_members(first, *plain));

  PolicyEnsemble second(fakes::tiny_policy(), 3, 2);
  const auto second_stats = second.train(episodes, short_training(10));
  ASSERT_TRUE(second.last_train_reused());
  EXPECT_EQ(second.last_train_seconds(), first.last_train_seconds());  // the cost is the training's
  ASSERT_EQ(second_stats.size(), first_stats.size());
  for (size_t m = 0; m < first_stats.size(); ++m) {
    EXPECT_EQ(second_stats[m].losses, first_stats[m].losses);
    EXPECT_EQ(second_stats[m].seconds, first_stats[m].seconds);
  }
  EXPECT_TRUE(same_members(second, *plain));  // bit for bit what training gives

  // the cells of an evaluation run in processes of their own: what one stored, another loads
  const auto child = run_in_children(1, 1, "training in another process", [&](int, const ReportFn&) {
    return std::string(trained(episodes, 12)->last_train_reused() ? "reused" : "trained");
  });
  ASSERT_EQ(child, std::vector<std::string>{"trained"});  // a new key: the child trained and stored it
  EXPECT_TRUE(trained(episodes, 12)->last_train_reused());

  // anything the training reads makes another key: the data, the config, the seed, the weights
  auto changed = episodes;
  changed[0].actions(0, 0) += 1e-3f;
  EXPECT_FALSE(trained(changed)->last_train_reused());
  EXPECT_FALSE(trained(episodes, 11)->last_train_reused());
  EXPECT_FALSE(trained(episodes, 10, 3)->last_train_reused());
  second.train(episodes, short_training(10));  // continues from its trained weights
  EXPECT_FALSE(second.last_train_reused());

  // a damaged entry is trained over, and the result is still training's
  int damaged = 0;
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (!fs::exists(entry.path() / "member_1.pt")) continue;
    fs::resize_file(entry.path() / "member_1.pt", 100);
    ++damaged;
  }
  EXPECT_GE(damaged, 1);
  const auto retrained = trained(episodes);
  EXPECT_FALSE(retrained->last_train_reused());
  EXPECT_TRUE(same_members(*retrained, *plain));
  EXPECT_TRUE(trained(episodes)->last_train_reused());  // and stored again
  fs::remove_all(dir);
}

TEST(Methods, TheLossIsScoredWithTheChosenWeights) {
  const auto episodes = bimodal_episodes(12, 10, 2, 2, /*seed=*/5);
  const ChunkDataset data = ChunkDataset::from_episodes(episodes, 8);
  DiffusionPolicy p(fakes::tiny_policy(), 4, false);
  TrainConfig t = short_training(60);
  t.ema_max_decay = 0.9;  // an EMA that lags visibly behind the raw weights
  train(p, data, t);
  const Vec obs = data.obs.row(0).transpose();
  const Mat chunk = data.chunk(0);
  const float ema = p.expected_loss(obs, chunk, 5, 64);
  p.set_score_weights(ScoreWeights::kRaw);
  const float raw = p.expected_loss(obs, chunk, 5, 64);
  EXPECT_NE(ema, raw);
  p.set_score_weights(ScoreWeights::kEma);
  EXPECT_FLOAT_EQ(p.expected_loss(obs, chunk, 5, 64), ema);
  // sampling always uses the EMA weights
  const Mat sampled = p.sample(obs, 3);
  p.set_score_weights(ScoreWeights::kRaw);
  EXPECT_TRUE(p.sample(obs, 3).isApprox(sampled));
}

TEST(Methods, ReinitialisingKeepsTheNormalisersAndDrawsNewWeights) {
  const auto episodes = bimodal_episodes(12, 10, 2, 2, /*seed=*/5);
  DiffusionPolicy p(fakes::tiny_policy(), 4, false);
  train(p, ChunkDataset::from_episodes(episodes, 8), short_training(30));
  const Vec obs = Vec::Constant(2, 0.1f);
  const Mat trained = p.sample(obs, 3);
  const Vec scale = p.obs_normalizer().scale();
  p.reinitialize(99);
  EXPECT_TRUE(p.obs_normalizer().scale().isApprox(scale));
  EXPECT_FALSE(p.sample(obs, 3).isApprox(trained, 1e-3f));
}

// Thrifty's critic reports its training's progress; saved and loaded (resume points) it gives the
// same Q values; a critic file of other sizes, a truncated one and a missing one are Errors naming the file.
TEST(Methods, TheRiskCriticSavesAndLoads) {
  namespace fs = std::filesystem;
  const auto episodes = bimodal_episodes(6, 10, 2, 2, /*seed=*/5);
  std::vector<RecordedEpisode> data = failing_robot_data(episodes);
  CriticConfig cc;
  cc.steps = 20;
  cc.hidden = 16;
  RiskCritic critic(2, 2, cc);
  std::vector<int> done;
  critic.train(data, [&](int d, int total, double loss) {
    EXPECT_EQ(total, cc.steps);
    EXPECT_TRUE(std::isfinite(loss));
    done.push_back(d);
  });
  // progress goes forward and ends at the last step
  ASSERT_FALSE(done.empty());
  EXPECT_TRUE(std::is_sorted(done.begin(), done.end()));
  EXPECT_EQ(done.back(), cc.steps);
  const fs::path file = fs::temp_directory_path() / ("dd_critic_" + std::to_string(::getpid()) + ".pt");
  critic.save(file.string());
  RiskCritic loaded(2, 2, cc);
  loaded.load(file.string());
  const Mat obs = episodes[0].obs, actions = episodes[0].actions;
  const std::vector<float> a = critic.q(obs, actions), b = loaded.q(obs, actions);
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) EXPECT_FLOAT_EQ(a[i], b[i]) << i;

  auto message = [](const std::function<void()>& f) {
    try {
      f();
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  RiskCritic wider(3, 2, cc);
  const std::string sizes = message([&] { wider.load(file.string()); });
  EXPECT_NE(sizes.find(file.string() + ": normaliser sizes (fields obs_scale, act_scale) do not match"), std::string::npos) << sizes;
  fs::resize_file(file, fs::file_size(file) / 2);
  const std::string truncated = message([&] { loaded.load(file.string()); });
  EXPECT_EQ(truncated.rfind(file.string() + ": ", 0), 0u) << truncated;
  fs::remove(file);
  EXPECT_EQ(message([&] { loaded.load(file.string()); }), file.string() + ": no such critic file");
}

TEST(FailurePrediction, EmptyClassesAreUndefinedNotZero) {
  std::vector<RolloutResult> all_succeed(5);
  for (auto& r : all_succeed) r.success = true;
  all_succeed[0].queried = true;
  FailurePrediction p = failure_prediction(all_succeed);
  EXPECT_TRUE(std::isnan(p.tpr));  // no failure to catch
  EXPECT_DOUBLE_EQ(p.tnr, 0.8);
  EXPECT_EQ(p.fp, 1);
  EXPECT_EQ(p.tn, 4);
  EXPECT_DOUBLE_EQ(p.f1, 0.0);     // 2TP / (2TP + FP + FN) = 0 / 1
  EXPECT_DOUBLE_EQ(p.accuracy, 0.8);

  std::vector<RolloutResult> all_fail_unqueried(3);
  p = failure_prediction(all_fail_unqueried);
  EXPECT_TRUE(std::isnan(p.tnr));
  EXPECT_DOUBLE_EQ(p.tpr, 0.0);
  EXPECT_EQ(p.fn, 3);

  std::vector<RolloutResult> all_succeed_unqueried(2);
  for (auto& r : all_succeed_unqueried) r.success = true;
  p = failure_prediction(all_succeed_unqueried);
  EXPECT_TRUE(std::isnan(p.f1));   // nothing positive at all: 0 / 0
  EXPECT_DOUBLE_EQ(p.accuracy, 1.0);
}

namespace {

class AlwaysViolates : public Method {
 public:
  explicit AlwaysViolates(bool gated) : gated_(gated) {}
  std::string name() const override { return "violates"; }
  bool gated() const override { return gated_; }
  UpdateReport update(const std::vector<Episode>&, const std::vector<RecordedEpisode>&, const TrainConfig&, const ProgressFn&) override {
    return {};
  }
  MethodDecision decide(const Vec&, uint64_t) override {
    MethodDecision d;
    d.chunk = Mat::Ones(8, 1);
    d.violation = true;
    return d;
  }
  float threshold() const override { return 0; }
  void save(const std::string&) const override {}

 private:
  bool gated_;
};

}  // namespace

TEST(Rollouts, TheGateScoresPerChunkOrPerStep) {
  fakes::LineEnv env(/*goal=*/12, /*limit=*/100);
  RolloutSpec spec{100, 3, 4, GateCadence::kChunk};
  AlwaysViolates gated(true), bc(false);
  auto r = evaluate_rollouts(env, gated, 1, spec, 0).front();
  EXPECT_EQ(r.decisions, 3);  // 12 steps in chunks of 4
  EXPECT_TRUE(r.success);
  EXPECT_TRUE(r.queried);
  EXPECT_EQ(r.first_query_step, 8);  // the 3rd chunk, K = 3 chunks
  spec.gate_every = GateCadence::kStep;
  r = evaluate_rollouts(env, gated, 1, spec, 0).front();
  EXPECT_EQ(r.decisions, 12);  // one scored chunk per step
  EXPECT_EQ(r.steps, 12);      // executing the same actions
  EXPECT_EQ(r.first_query_step, 2);  // K = 3 steps
  r = evaluate_rollouts(env, bc, 1, spec, 0).front();
  EXPECT_EQ(r.decisions, 3);  // a method that never asks has nothing to score between chunks
  EXPECT_FALSE(r.queried);
}

namespace {

// Violates on every decision; of its two compared rules the first violates on every other decision,
// the second never.
class ComparesTwoRules : public AlwaysViolates {
 public:
  ComparesTwoRules() : AlwaysViolates(true) {}
  std::vector<std::string> compare_rules() const override { return {"alternating", "never"}; }
  MethodDecision decide(const Vec& obs, uint64_t seed) override {
    MethodDecision d = AlwaysViolates::decide(obs, seed);
    d.compare_violations = {static_cast<uint8_t>(n_++ % 2 == 0), 0};
    return d;
  }

 private:
  int n_ = 0;
};

}  // namespace

TEST(Rollouts, ComparedRulesAreJudgedOnTheSameRollouts) {
  fakes::LineEnv env(/*goal=*/12, /*limit=*/100);
  ComparesTwoRules m;
  const auto results = evaluate_rollouts(env, m, 3, RolloutSpec{100, 2, 4, GateCadence::kChunk}, 0);
  for (const RolloutResult& r : results) {
    EXPECT_TRUE(r.queried);
    ASSERT_EQ(r.compare_queried.size(), 2u);
    EXPECT_EQ(r.compare_queried[0], 0);  // never two violations in a row (K = 2)
    EXPECT_EQ(r.compare_queried[1], 0);
  }
  const FailurePrediction main_rule = failure_prediction(results), never = failure_prediction(results, 1);
  EXPECT_EQ(main_rule.fp, 3);  // every rollout succeeds and was queried
  EXPECT_EQ(never.tn, 3);
  EXPECT_THROW(failure_prediction(results, 2), Error);
  // K = 1: the alternating rule asks at its first violation
  const auto eager = evaluate_rollouts(env, m, 1, RolloutSpec{100, 1, 4, GateCadence::kChunk}, 0);
  EXPECT_EQ(eager.front().compare_queried[0], 1);
}

TEST(Rollouts, JudgedByAComparedRuleTakesItsVerdictAndStep) {
  RolloutResult r;
  r.queried = true;  // the method's own rule asked at step 8
  r.first_query_step = 8;
  r.compare_queried = {0, 1};
  r.compare_first_query_step = {-1, 24};
  RolloutResult older = r;  // written before the compared rules' steps were recorded
  older.compare_first_query_step.clear();
  const auto by_second = judged_by({r, older}, 1);
  ASSERT_EQ(by_second.size(), 2u);
  EXPECT_TRUE(by_second[0].queried);
  EXPECT_EQ(by_second[0].first_query_step, 24);
  EXPECT_TRUE(by_second[0].compare_queried.empty());
  EXPECT_TRUE(by_second[0].compare_first_query_step.empty());
  EXPECT_TRUE(by_second[1].queried);
  EXPECT_EQ(by_second[1].first_query_step, -1);  // asked, at a step not recorded
  const auto by_first = judged_by({r}, 0);
  EXPECT_FALSE(by_first[0].queried);
  EXPECT_EQ(by_first[0].first_query_step, -1);
  EXPECT_EQ(failure_prediction({r}, 0).fn, 1);  // a failure the first compared rule did not ask in
  EXPECT_EQ(failure_prediction({r}, 1).tp, 1);
  EXPECT_THROW(judged_by({r}, 2), Error);
}

namespace {

// Acts and judges from the decision's seed alone (as the real methods do): steps of 0.2 to 1.0, a
// violation on two seeds in a row of every six, its compared rule on every other.
class SeededMethod : public AlwaysViolates {
 public:
  SeededMethod() : AlwaysViolates(true) {}
  std::vector<std::string> compare_rules() const override { return {"even"}; }
  MethodDecision decide(const Vec&, uint64_t seed) override {
    MethodDecision d;
    d.chunk = Mat::Constant(4, 1, 0.2f + 0.2f * static_cast<float>(((seed * 0x9E3779B97F4A7C15ull) >> 59) % 5));
    d.violation = (seed / 2) % 3 == 0;
    d.compare_violations = {static_cast<uint8_t>(seed % 2 == 0)};
    return d;
  }
};

bool same(const RolloutResult& a, const RolloutResult& b) {
  return a.success == b.success && a.queried == b.queried && a.first_query_step == b.first_query_step && a.steps == b.steps &&
         a.decisions == b.decisions && a.outcome == b.outcome && a.compare_queried == b.compare_queried;
}

}  // namespace

// At 2 threads two one-thread child processes take alternate episodes and hand them back in order:
// the same episodes as one process, and a failing consumer stops them.
TEST(Rollouts, TwoProcessesGiveTheEpisodesOfOne) {
  fakes::LineEnv env(/*goal=*/12, /*limit=*/20);
  SeededMethod m;
  const RolloutSpec spec{20, 2, 4, GateCadence::kChunk};
  const int threads = num_threads();
  set_num_threads(2);
  set_data_parallel(false);
  const std::vector<RolloutResult> one = evaluate_rollouts(env, m, 9, spec, 100);
  set_data_parallel(true);
  const int started = children_started();
  const std::vector<RolloutResult> two = evaluate_rollouts(env, m, 9, spec, 100);
  EXPECT_EQ(children_started(), started + 2);
  ASSERT_EQ(two.size(), one.size());
  int failed = 0, queried = 0;
  for (size_t e = 0; e < one.size(); ++e) {
    EXPECT_TRUE(same(one[e], two[e])) << "episode " << e;
    failed += !one[e].success;
    queried += one[e].queried;
  }
  EXPECT_GT(failed, 0);  // the episodes differ from one another, so an order mix-up would show
  EXPECT_LT(failed, 9);
  EXPECT_GT(queried, 0);
  // a range, in order, from the first episode asked for
  std::vector<int> order;
  evaluate_rollouts_each(env, m, 3, 8, spec, 100, [&](int e, const RolloutResult& r) {
    EXPECT_TRUE(same(r, one[static_cast<size_t>(e)])) << "episode " << e;
    order.push_back(e);
  });
  EXPECT_EQ(order, (std::vector<int>{3, 4, 5, 6, 7}));
  // a consumer that throws (a full disk) stops the children: none is left behind
  EXPECT_THROW(evaluate_rollouts_each(env, m, 0, 9, spec, 100,
                                      [](int e, const RolloutResult&) {
                                        if (e == 2) throw Error("disk full");
                                      }),
               Error);
  EXPECT_EQ(::waitpid(-1, nullptr, WNOHANG), -1);  // no child process at all (ECHILD)
  set_num_threads(threads);
}

TEST(Methods, ScoreRulesParseAndName) {
  EXPECT_EQ(ScoreRule::parse("target").name(), "target");
  const ScoreRule low = ScoreRule::parse("epsilon@4");
  EXPECT_EQ(low.space, "epsilon");
  EXPECT_EQ(low.timesteps, 4);
  EXPECT_EQ(low.name(), "epsilon@4");
  for (const char* bad : {"targets", "target@0", "target@", "epsilon@x", "@4"}) {
    try {
      ScoreRule::parse(bad);
      ADD_FAILURE() << bad << " parsed";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(std::string("'") + bad + "'"), std::string::npos) << e.what();
    }
  }
}

TEST(Methods, DiffJudgesItsComparedRulesWithThresholdsOfTheirOwn) {
  const auto episodes = bimodal_episodes(12, 10, 2, 2, /*seed=*/5);
  MethodConfig mc = small_method();
  mc.compare_scores = {"target", "target@1", "epsilon"};
  auto m = make_method("diff", fakes::tiny_policy(), mc, 1);
  EXPECT_EQ(m->compare_rules(), (std::vector<std::string>{"target", "target@1", "epsilon"}));
  m->update(episodes, {}, short_training());
  // The same method scoring in epsilon space itself: the same training, so the same policy.
  MethodConfig eps_config = small_method();
  eps_config.score_space = "epsilon";
  auto eps = make_method("diff", fakes::tiny_policy(), eps_config, 1);
  eps->update(episodes, {}, short_training());
  // "target" is the main rule over the main rule's own rows: the same score and verdict at every
  // decision. "epsilon" is scored from those rows too: exactly what a method scoring in epsilon space
  // gives for the same decision. "target@1" (the lowest-noise timestep alone) has rows of its own and
  // scores something else.
  int n = 0;
  double main_sum = 0, low_sum = 0;
  for (const Episode& e : episodes)
    for (Eigen::Index t = 0; t < e.obs.rows(); t += 3, ++n) {
      const Vec obs = e.obs.row(t).transpose();
      const uint64_t seed = 100 + static_cast<uint64_t>(n);
      const MethodDecision d = m->decide(obs, seed);
      ASSERT_EQ(d.compare_scores.size(), 3u);
      ASSERT_EQ(d.compare_violations.size(), 3u);
      EXPECT_EQ(d.compare_scores[0], d.score);
      EXPECT_EQ(d.compare_violations[0] != 0, d.violation);
      const MethodDecision by_eps = eps->decide(obs, seed);
      EXPECT_EQ(d.compare_scores[2], by_eps.score);
      EXPECT_EQ(d.compare_violations[2] != 0, by_eps.violation);
      main_sum += d.score;
      low_sum += d.compare_scores[1];
    }
  EXPECT_GT(std::abs(low_sum / main_sum - 1.0), 0.2);
  // the main rule is unchanged by the compared ones: same policy seed, same decision
  MethodConfig plain = small_method();
  auto reference = make_method("diff", fakes::tiny_policy(), plain, 1);
  reference->update(episodes, {}, short_training());
  EXPECT_FLOAT_EQ(reference->threshold(), m->threshold());
  const MethodDecision a = reference->decide(episodes[0].obs.row(0).transpose(), 9), b = m->decide(episodes[0].obs.row(0).transpose(), 9);
  EXPECT_FLOAT_EQ(a.score, b.score);
  EXPECT_TRUE(a.chunk.isApprox(b.chunk, 1e-6f));
  // a rule drawing from more timesteps than the policy has is refused when the method is built
  mc.compare_scores = {"epsilon@999"};
  EXPECT_THROW(make_method("diff", fakes::tiny_policy(), mc, 1), Error);
}

}  // namespace dd

namespace dd {

TEST(Methods, TheRegistryDescribesEveryMethodItBuilds) {
  for (const MethodInfo& info : method_registry()) {
    auto m = make_method(info.name, fakes::tiny_policy(), small_method(), 1);
    EXPECT_EQ(m->name(), info.name);
    EXPECT_EQ(m->gated(), info.gated) << info.name;
    EXPECT_EQ(info.score.empty(), !info.gated) << info.name << ": a method that asks says what its score is";
    EXPECT_FALSE(info.title.empty());
  }
  try {
    make_method("dagger", fakes::tiny_policy(), small_method(), 1);
    ADD_FAILURE() << "an unknown method was built";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("'dagger' (known: diff, ensemble, thrifty, bc)"), std::string::npos) << e.what();
  }
}

// Diff-DAgger screens its gate (DiffusionPolicy::decide_screened) unless told not to or unless compared
// rules need all the rows: the same chunk, the same verdict against the same threshold, fewer rows
// where the score lies well below it.
TEST(Methods, DiffScreensItsGateWhereOnlyTheVerdictCounts) {
  const auto episodes = bimodal_episodes(12, 10, 2, 2, /*seed=*/5);
  auto build = [&](bool screen, std::vector<std::string> compare) {
    MethodConfig mc = small_method();
    mc.loss_samples = 128;  // T_d 16: screening rows 32, then 64, 128 in all
    mc.screen_gate = screen;
    mc.compare_scores = std::move(compare);
    auto m = make_method("diff", fakes::tiny_policy(), mc, 1);
    m->update(episodes, {}, short_training());
    return m;
  };
  auto screened = build(true, {}), full = build(false, {}), compared = build(true, {"epsilon"});
  ASSERT_FLOAT_EQ(screened->threshold(), full->threshold()) << "the same training and threshold";
  int early = 0, n = 0;
  for (const Episode& e : episodes)
    for (Eigen::Index t = 0; t < e.obs.rows(); t += 2, ++n) {
      const Vec obs = e.obs.row(t).transpose();
      const uint64_t seed = 300 + static_cast<uint64_t>(n);
      const MethodDecision a = screened->decide(obs, seed), b = full->decide(obs, seed), c = compared->decide(obs, seed);
      EXPECT_TRUE(a.chunk.isApprox(b.chunk, 0.f));
      EXPECT_EQ(b.score_rows, 128);
      EXPECT_EQ(c.score_rows, 128) << "compared rules score the main rule's own rows";
      EXPECT_TRUE(a.score_rows == 32 || a.score_rows == 64 || a.score_rows == 128) << a.score_rows;
      EXPECT_EQ(a.violation, violates(a.score, a.threshold));
      if (a.score_rows < 128) {
        ++early;
        EXPECT_FALSE(a.violation);
        EXPECT_LT(a.score, a.threshold);
      }
    }
  EXPECT_GT(early, n / 2) << "most decisions along the demonstrations lie well below the 0.99-quantile";
}

TEST(Methods, ADecisionSaysWhyItViolates) {
  const auto episodes = bimodal_episodes(12, 10, 2, 2, /*seed=*/5);
  MethodConfig mc = small_method();
  mc.alpha = 0.3;  // a low threshold: some decisions along the data violate it, some do not
  auto m = make_method("diff", fakes::tiny_policy(), mc, 1);
  m->update(episodes, {}, short_training());
  int violations = 0;
  for (uint64_t i = 0; i < 24; ++i) {
    const Vec obs = episodes[i % episodes.size()].obs.row(static_cast<Eigen::Index>(i % 10)).transpose();
    const MethodDecision d = m->decide(obs, i);
    EXPECT_EQ(d.violation, violates(d.score, d.threshold));
    EXPECT_EQ(d.reason, d.violation ? QueryReason::kScore : QueryReason::kNone);
    violations += d.violation;
  }
  EXPECT_GT(violations, 0);
  EXPECT_LT(violations, 24);
}

// Thrifty's rule asks when the ensemble's spread is above its threshold (novelty) or the critic's
// success estimate is below gamma (risk); each half is also judged alone, on the same decision, so
// that an evaluation can say which of them asked (rollouts gate compared rules like the rule:
// Rollouts.ComparedRulesAreJudgedOnTheSameRollouts).
TEST(Methods, ThriftyJudgesEachHalfOfItsRuleAlone) {
  const auto episodes = bimodal_episodes(12, 10, 2, 2, /*seed=*/5);
  MethodConfig mc = small_method();
  mc.alpha = 0.3;  // a low threshold: some decisions along the data are novel, some not
  auto m = make_method("thrifty", fakes::tiny_policy(), mc, 1);
  EXPECT_EQ(m->compare_rules(), (std::vector<std::string>{"novelty", "risk"}));
  EXPECT_TRUE(std::isnan(m->risk_threshold())) << "gamma before the critic has trained";
  EXPECT_TRUE(std::isnan(make_method("ensemble", fakes::tiny_policy(), mc, 1)->risk_threshold()));
  m->update(episodes, failing_robot_data(episodes), short_training());
  ASSERT_TRUE(std::isfinite(m->risk_threshold()));
  int novel = 0, asked = 0;
  for (uint64_t i = 0; i < 24; ++i) {
    const Vec obs = episodes[i % episodes.size()].obs.row(static_cast<Eigen::Index>(i % 10)).transpose();
    const MethodDecision d = m->decide(obs, i);
    ASSERT_EQ(d.compare_violations.size(), 2u);
    ASSERT_EQ(d.compare_scores.size(), 2u);
    const bool novelty = d.compare_violations[0], risk = d.compare_violations[1];
    EXPECT_EQ(novelty, violates(d.score, d.threshold));
    EXPECT_EQ(risk, violates(-d.risk_q, -m->risk_threshold())) << "the risk half asks below gamma";
    EXPECT_FLOAT_EQ(d.compare_scores[0], d.score);
    EXPECT_FLOAT_EQ(d.compare_scores[1], d.risk_q);
    EXPECT_EQ(d.violation, novelty || risk);
    EXPECT_EQ(d.reason, novelty ? QueryReason::kScore : risk ? QueryReason::kRisk : QueryReason::kNone);
    novel += novelty;
    asked += d.violation;
  }
  EXPECT_GT(novel, 0);
  EXPECT_LT(novel, 24);
  EXPECT_GE(asked, novel);
}

}  // namespace dd
