#include "core/method.h"

#include <chrono>
#include <cmath>
#include <filesystem>

#include <nlohmann/json.hpp>

#include "core/ensemble.h"
#include "core/gate.h"
#include "core/policy.h"
#include "core/text_file.h"
#include "core/trainer.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

namespace dd {
namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

// Thresholds are infinite before the first update; JSON has no infinity, so they are written as null.
nlohmann::json number_or_null(float v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }
float number_or_inf(const nlohmann::json& j) { return j.is_null() ? INFINITY : j.get<float>(); }

class DiffMethod : public Method {
 public:
  DiffMethod(const PolicyConfig& pc, const MethodConfig& mc, uint64_t seed) : policy_(pc, seed), config_(mc), seed_(seed) {
    policy_.set_score_weights(mc.score_raw_weights ? ScoreWeights::kRaw : ScoreWeights::kEma);
    main_rule_ = {mc.score_space, mc.score_timesteps};
    use(main_rule_);
    policy_.set_inference_precision(inference_precision_from(mc.precision));
    const int own_timesteps = policy_.score_timesteps();
    for (const std::string& r : mc.compare_scores) {
      compare_.push_back(ScoreRule::parse(r));
      ScoredBy check(*this, compare_.back());  // checks the rule against T_d now rather than at the first decision
      // A rule over the method's own timesteps is scored from the decision's own rows, in its space;
      // one over other timesteps needs rows of its own.
      if (policy_.score_timesteps() == own_timesteps) {
        compare_shared_.push_back(static_cast<int>(shared_spaces_.size()));
        shared_spaces_.push_back(policy_.score_space());
      } else {
        compare_shared_.push_back(-1);
      }
    }
    compare_thresholds_.assign(compare_.size(), INFINITY);
  }
  std::string name() const override { return "diff"; }
  std::vector<std::string> compare_rules() const override {
    std::vector<std::string> names;
    for (const ScoreRule& r : compare_) names.push_back(r.name());
    return names;
  }

  UpdateReport update(const std::vector<Episode>& expert, const std::vector<RecordedEpisode>&, const TrainConfig& train_config,
                      const ProgressFn& progress) override {
    UpdateReport r;
    const ChunkDataset data = ChunkDataset::from_episodes(expert, policy_.config().horizon);
    r.pairs = data.size();
    auto t = Clock::now();
    if (train_config.from_scratch && updates_ > 0) policy_.reinitialize(seed_ + 7919 * updates_);
    r.final_loss = train(policy_, data, train_config, progress).last_mean();
    r.train_s = since(t);
    set_threshold(data, r, progress);  // a second count after training's (ProgressBar shows it as "part 2")
    return r;
  }

  UpdateReport adopt(const std::vector<std::string>& checkpoints, const std::vector<Episode>& expert,
                     const std::vector<RecordedEpisode>&, const ProgressFn& progress) override {
    if (checkpoints.empty()) throw Error("diff: adopt needs a policy checkpoint");
    policy_.load(checkpoints.front());
    UpdateReport r;
    const ChunkDataset data = ChunkDataset::from_episodes(expert, policy_.config().horizon);
    r.pairs = data.size();
    set_threshold(data, r, progress);
    return r;
  }

  MethodDecision decide(const Vec& obs, uint64_t seed) override {
    // Screened when the verdict is all that counts: compared rules score the very rows of the method's
    // own score, so they need all of them.
    const Decision d = config_.screen_gate && compare_.empty() ? policy_.decide_screened(obs, seed, config_.loss_samples, threshold_)
                                                               : policy_.decide(obs, seed, config_.loss_samples, shared_spaces_);
    MethodDecision m;
    m.chunk = d.chunk;
    m.score = d.loss;
    m.score_rows = d.rows;
    m.threshold = threshold_;
    m.violation = violates(d.loss, threshold_);
    m.reason = m.violation ? QueryReason::kScore : QueryReason::kNone;
    // The compared rules score the same chunk, each in its own way: those over the method's own
    // timesteps from the very rows its score came from (a paired comparison, and no further pass of
    // the network), the others with rows and noise of their own.
    for (size_t i = 0; i < compare_.size(); ++i) {
      float loss;
      if (compare_shared_[i] >= 0) {
        loss = d.also[static_cast<size_t>(compare_shared_[i])];
      } else {
        ScoredBy rule(*this, compare_[i]);
        loss = policy_.expected_loss(obs, d.chunk, seed ^ (0x5C0E'0000'0000'0000ull + i), config_.loss_samples);
      }
      m.compare_scores.push_back(loss);
      m.compare_violations.push_back(violates(loss, compare_thresholds_[i]));
    }
    return m;
  }
  float threshold() const override { return threshold_; }
  void save(const std::string& dir) const override { policy_.save(dir + "/policy.pt"); }

 private:
  void use(const ScoreRule& r) {
    policy_.set_score_space(score_space_from(r.space));
    policy_.set_score_timesteps(r.timesteps);
  }
  // The policy scores by a compared rule while one of these lives, and by the method's own rule again
  // when it goes, also when scoring throws.
  class ScoredBy {
   public:
    ScoredBy(DiffMethod& m, const ScoreRule& r) : m_(m) { m_.use(r); }
    ~ScoredBy() { m_.use(m_.main_rule_); }
    ScoredBy(const ScoredBy&) = delete;
    ScoredBy& operator=(const ScoredBy&) = delete;

   private:
    DiffMethod& m_;
  };
  // The alpha-quantile of the expected loss over the training pairs (a subset when calibration_pairs),
  // and of each compared rule's score over the same pairs. `progress` counts the passes of all the
  // rules as one: rule i's pass is the i-th of 1 + compared rules equal parts.
  void set_threshold(const ChunkDataset& data, UpdateReport& r, const ProgressFn& progress = {}) {
    const auto t = Clock::now();
    const ChunkDataset cal = data.subset(config_.calibration_pairs, seed_ + ++updates_);
    const int passes = 1 + static_cast<int>(compare_.size());
    int pass = 0;
    auto quantile = [&](bool main_rule) {
      ProgressFn part;
      if (progress)
        part = [&, base = pass++](int done, int total, double value) {
          progress(base * total + done, passes * total, value);
        };
      const LossQuantile q = policy_.loss_quantile(cal, config_.alpha, seed_ * 31 + updates_, config_.loss_samples,
                                                   config_.screen_threshold, part);
      spdlog::debug("diff: threshold {:.5f} over {} pairs, {} of them at {} rows (screened at {})", q.threshold, q.pairs, q.refined,
                    config_.loss_samples, q.screen_samples);
      if (main_rule) {
        r.threshold_pairs = q.pairs;
        r.threshold_refined = q.refined;
      }
      return q.threshold;
    };
    threshold_ = quantile(true);
    r.threshold_s = since(t);  // the compared rules' thresholds are not the method's cost
    r.threshold = threshold_;
    for (size_t i = 0; i < compare_.size(); ++i) {
      ScoredBy rule(*this, compare_[i]);
      compare_thresholds_[i] = quantile(false);
    }
  }

 protected:
  nlohmann::json state(const std::string& /*dir*/) const override {
    nlohmann::json j{{"updates", updates_}, {"threshold", number_or_null(threshold_)}};
    for (size_t i = 0; i < compare_.size(); ++i) j["compare_thresholds"][compare_[i].name()] = number_or_null(compare_thresholds_[i]);
    return j;
  }
  void restore(const nlohmann::json& j, const std::string& dir) override {
    // the fields first: a state missing one leaves the policy as it was
    const uint64_t updates = j.at("updates").get<uint64_t>();
    const float threshold = number_or_inf(j.at("threshold"));
    std::vector<float> compared(compare_.size());
    for (size_t i = 0; i < compare_.size(); ++i) compared[i] = number_or_inf(j.at("compare_thresholds").at(compare_[i].name()));
    policy_.load(dir + "/policy.pt");
    updates_ = updates;
    threshold_ = threshold;
    compare_thresholds_ = std::move(compared);
  }

 private:
  DiffusionPolicy policy_;
  MethodConfig config_;
  uint64_t seed_;
  uint64_t updates_ = 0;
  float threshold_ = INFINITY;
  ScoreRule main_rule_;
  std::vector<ScoreRule> compare_;
  std::vector<float> compare_thresholds_;
  std::vector<int> compare_shared_;         // per compared rule: its index in shared_spaces_, or -1
  std::vector<ScoreSpace> shared_spaces_;  // scored from the decision's own rows
};

class EnsembleMethod : public Method {
 public:
  EnsembleMethod(const PolicyConfig& pc, const MethodConfig& mc, uint64_t seed)
      : ensemble_(pc, mc.members, seed), config_(mc), seed_(seed) {
    for (int i = 0; i < ensemble_.size(); ++i) ensemble_.member(i).set_inference_precision(inference_precision_from(mc.precision));
  }
  std::string name() const override { return "ensemble"; }

  UpdateReport update(const std::vector<Episode>& expert, const std::vector<RecordedEpisode>&, const TrainConfig& train_config,
                      const ProgressFn& progress) override {
    UpdateReport r;
    const ChunkDataset data = ChunkDataset::from_episodes(expert, ensemble_.member(0).config().horizon);
    r.pairs = data.size();
    if (train_config.from_scratch && updates_ > 0) ensemble_.reinitialize(seed_ + 7919 * updates_);
    const auto stats = ensemble_.train(expert, train_config, progress);
    r.final_loss = stats.front().last_mean();
    // The training's own wall-clock, without the cache's bookkeeping; for a cache hit, which loads in
    // a second what took minutes, the training's when it ran: the method's cost either way.
    r.train_s = ensemble_.last_train_seconds();
    r.train_reused = ensemble_.last_train_reused();
    set_threshold(data, r, progress);  // a second count after training's (ProgressBar shows it as "part 2")
    return r;
  }

  UpdateReport adopt(const std::vector<std::string>& checkpoints, const std::vector<Episode>& expert,
                     const std::vector<RecordedEpisode>&, const ProgressFn& progress) override {
    if (static_cast<int>(checkpoints.size()) != ensemble_.size())
      throw Error(fmt::format("{}: adopt needs one checkpoint per member ({}), got {}", name(), ensemble_.size(), checkpoints.size()));
    ensemble_.load_members(checkpoints);
    UpdateReport r;
    const ChunkDataset data = ChunkDataset::from_episodes(expert, ensemble_.member(0).config().horizon);
    r.pairs = data.size();
    set_threshold(data, r, progress);
    return r;
  }

  MethodDecision decide(const Vec& obs, uint64_t seed) override {
    const PolicyEnsemble::Decision d = ensemble_.decide(obs, seed);
    MethodDecision m;
    m.chunk = d.chunk;
    m.score = d.variance;
    m.threshold = threshold_;
    m.violation = violates(d.variance, threshold_);
    m.reason = m.violation ? QueryReason::kScore : QueryReason::kNone;
    return m;
  }
  float threshold() const override { return threshold_; }
  void save(const std::string& dir) const override {
    for (int i = 0; i < ensemble_.size(); ++i) ensemble_.member(i).save(dir + "/member_" + std::to_string(i) + ".pt");
  }

 protected:
  // The alpha-quantile of the members' spread over the training pairs: every member samples at every
  // pair, in one batch each; `progress` counts the members that have sampled.
  void set_threshold(const ChunkDataset& data, UpdateReport& r, const ProgressFn& progress = {}) {
    const auto t = Clock::now();
    const ChunkDataset cal = data.subset(config_.calibration_pairs, seed_ + ++updates_);
    threshold_ = quantile(ensemble_.action_variance(cal.obs, seed_ * 31 + updates_, progress), config_.alpha);
    r.threshold_s = since(t);
    r.threshold = threshold_;
  }
  nlohmann::json state(const std::string& /*dir*/) const override { return {{"updates", updates_}, {"threshold", number_or_null(threshold_)}}; }
  void restore(const nlohmann::json& j, const std::string& dir) override {
    // the fields first, then the members all or nothing: a bad file leaves the method as it was
    const uint64_t updates = j.at("updates").get<uint64_t>();
    const float threshold = number_or_inf(j.at("threshold"));
    std::vector<std::string> files;
    for (int i = 0; i < ensemble_.size(); ++i) files.push_back(dir + "/member_" + std::to_string(i) + ".pt");
    ensemble_.load_members(files);
    updates_ = updates;
    threshold_ = threshold;
  }

  PolicyEnsemble ensemble_;
  MethodConfig config_;
  uint64_t seed_;
  uint64_t updates_ = 0;
  float threshold_ = INFINITY;
};

class ThriftyMethod : public EnsembleMethod {
 public:
  ThriftyMethod(const PolicyConfig& pc, const MethodConfig& mc, uint64_t seed)
      : EnsembleMethod(pc, mc, seed), critic_(pc.obs_dim, pc.action_dim, critic_config(mc, seed)) {}
  std::string name() const override { return "thrifty"; }

  UpdateReport update(const std::vector<Episode>& expert, const std::vector<RecordedEpisode>& robot, const TrainConfig& train_config,
                      const ProgressFn& progress) override {
    UpdateReport r = EnsembleMethod::update(expert, robot, train_config, progress);
    const auto [train_s, threshold_s] = fit_risk(expert, robot, progress);
    r.train_s += train_s;
    r.threshold_s += threshold_s;
    return r;
  }

  UpdateReport adopt(const std::vector<std::string>& checkpoints, const std::vector<Episode>& expert,
                     const std::vector<RecordedEpisode>& robot, const ProgressFn& progress) override {
    UpdateReport r = EnsembleMethod::adopt(checkpoints, expert, robot, progress);
    const auto [train_s, threshold_s] = fit_risk(expert, robot, progress);
    r.train_s += train_s;
    r.threshold_s += threshold_s;
    return r;
  }

  double refit_risk(const std::vector<Episode>& expert, const std::vector<RecordedEpisode>& robot) override {
    const auto [train_s, threshold_s] = fit_risk(expert, robot);
    return train_s + threshold_s;
  }

  // The rule's two halves, each judged alone on the same decisions: which of them asks.
  std::vector<std::string> compare_rules() const override { return {"novelty", "risk"}; }
  float risk_threshold() const override { return updates_ > 0 ? gamma_ : NAN; }

  MethodDecision decide(const Vec& obs, uint64_t seed) override {
    MethodDecision m = EnsembleMethod::decide(obs, seed);
    m.risk_q = critic_.q(obs.transpose(), m.chunk.row(0)).front();
    // risk: the critic's success estimate below gamma (a lower bound: the rule on -Q and -gamma)
    const bool risky = violates(-m.risk_q, -gamma_);
    m.compare_scores = {m.score, m.risk_q};
    m.compare_violations = {static_cast<uint8_t>(m.violation), static_cast<uint8_t>(risky)};
    if (!m.violation && risky) {
      m.violation = true;
      m.reason = QueryReason::kRisk;
    }
    return m;
  }

 protected:
  nlohmann::json state(const std::string& dir) const override {
    nlohmann::json j = EnsembleMethod::state(dir);
    j["gamma"] = gamma_;
    if (updates_ > 0) critic_.save(dir + "/critic.pt");
    return j;
  }
  void restore(const nlohmann::json& j, const std::string& dir) override {
    // Everything read before anything changes: a bad field or file leaves the method as it was.
    // Before the first update the critic has never trained and its file is not written.
    const float gamma = j.at("gamma").get<float>();
    const bool has_critic = j.at("updates").get<uint64_t>() > 0;
    const PolicyConfig& pc = ensemble_.member(0).config();
    RiskCritic critic(pc.obs_dim, pc.action_dim, critic_config(config_, seed_));
    if (has_critic) critic.load(dir + "/critic.pt");
    EnsembleMethod::restore(j, dir);
    gamma_ = gamma;
    if (has_critic) critic_ = std::move(critic);
  }

 private:
  // Risk: Q learned from the demonstrations (successes: failed expert episodes never reach training)
  // and the robot's rollouts (its episodes and the robot's part of intervened ones, which end in a
  // non-success at the takeover). gamma is a low quantile of Q over the robot's own states (the
  // demonstrations' when there are none yet). Returns the seconds spent training and setting gamma.
  // `progress` follows the critic's steps (a count after the threshold's: ProgressBar's next part).
  std::pair<double, double> fit_risk(const std::vector<Episode>& expert, const std::vector<RecordedEpisode>& robot,
                                     const ProgressFn& progress = {}) {
    auto t = Clock::now();
    std::vector<RecordedEpisode> transitions;
    for (const Episode& e : expert) {
      RecordedEpisode re;
      re.obs = e.obs;
      re.actions = e.actions;
      re.success = true;
      transitions.push_back(std::move(re));
    }
    transitions.insert(transitions.end(), robot.begin(), robot.end());
    critic_.train(transitions, progress);
    const double train_s = since(t);
    t = Clock::now();
    const std::vector<RecordedEpisode>& source = robot.empty() ? transitions : robot;
    std::vector<Vec> obs, act;
    for (const auto& e : source)
      for (Eigen::Index i = 0; i < e.steps(); ++i) {
        obs.push_back(e.obs.row(i).transpose());
        act.push_back(e.actions.row(i).transpose());
      }
    gamma_ = quantile(critic_.q(stack_rows(obs, expert.front().obs.cols()), stack_rows(act, expert.front().actions.cols())),
                      config_.risk_quantile);
    return {train_s, since(t)};
  }

  static CriticConfig critic_config(const MethodConfig& mc, uint64_t seed) {
    CriticConfig c = mc.critic;
    c.seed = seed;
    return c;
  }
  RiskCritic critic_;
  float gamma_ = 0;
};

// Acts with one policy and never asks: behaviour cloning, and rollouts of a trained policy.
class UngatedMethod : public Method {
 public:
  bool gated() const override { return false; }
  MethodDecision decide(const Vec& obs, uint64_t seed) override {
    MethodDecision m;
    m.chunk = acting().sample(obs, seed);
    return m;
  }
  float threshold() const override { return INFINITY; }
  void save(const std::string& dir) const override { acting().save(dir + "/policy.pt"); }

 protected:
  virtual const DiffusionPolicy& acting() const = 0;
};

class BcMethod : public UngatedMethod {
 public:
  BcMethod(const PolicyConfig& pc, const MethodConfig& mc, uint64_t seed) : policy_(pc, seed), seed_(seed) {
    policy_.set_inference_precision(inference_precision_from(mc.precision));
  }
  std::string name() const override { return "bc"; }

  UpdateReport update(const std::vector<Episode>& expert, const std::vector<RecordedEpisode>&, const TrainConfig& train_config,
                      const ProgressFn& progress) override {
    UpdateReport r;
    const ChunkDataset data = ChunkDataset::from_episodes(expert, policy_.config().horizon);
    r.pairs = data.size();
    const auto t = Clock::now();
    if (train_config.from_scratch && trained_) policy_.reinitialize(seed_ + 7919);
    trained_ = true;
    r.final_loss = train(policy_, data, train_config, progress).last_mean();
    r.train_s = since(t);
    return r;
  }

  UpdateReport adopt(const std::vector<std::string>& checkpoints, const std::vector<Episode>& expert,
                     const std::vector<RecordedEpisode>&, const ProgressFn&) override {
    if (checkpoints.empty()) throw Error("bc: adopt needs a policy checkpoint");
    policy_.load(checkpoints.front());
    trained_ = true;
    UpdateReport r;
    r.pairs = ChunkDataset::from_episodes(expert, policy_.config().horizon).size();
    return r;
  }

 protected:
  nlohmann::json state(const std::string& /*dir*/) const override { return {{"trained", trained_}}; }
  void restore(const nlohmann::json& j, const std::string& dir) override {
    policy_.load(dir + "/policy.pt");
    trained_ = j.at("trained").get<bool>();
  }

 private:
  const DiffusionPolicy& acting() const override { return policy_; }
  DiffusionPolicy policy_;
  uint64_t seed_;
  bool trained_ = false;
};

// A borrowed policy: trained by its owner, only rolled out here.
class PolicyActor : public UngatedMethod {
 public:
  explicit PolicyActor(const DiffusionPolicy& p) : policy_(p) {}
  std::string name() const override { return "policy"; }
  UpdateReport update(const std::vector<Episode>&, const std::vector<RecordedEpisode>&, const TrainConfig&,
                      const ProgressFn&) override {
    throw Error("a borrowed policy is trained by its owner, not through Method::update");
  }


 private:
  const DiffusionPolicy& acting() const override { return policy_; }
  const DiffusionPolicy& policy_;
};

}  // namespace

UpdateReport Method::adopt(const std::vector<std::string>&, const std::vector<Episode>&, const std::vector<RecordedEpisode>&,
                           const ProgressFn&) {
  throw Error(name() + ": trains no policies of its own to adopt checkpoints into");
}

nlohmann::json Method::state(const std::string&) const { return nlohmann::json::object(); }

void Method::restore(const nlohmann::json&, const std::string& dir) {
  throw Error(dir + ": method '" + name() + "' keeps no state of its own to restore");
}

void Method::save_state(const std::string& dir) const {
  std::filesystem::create_directories(dir);
  save(dir);
  nlohmann::json j = state(dir);
  j["method"] = name();
  write_text(dir + "/method.json", j.dump(2) + "\n");
}

void Method::load_state(const std::string& dir) {
  const std::string path = dir + "/method.json";
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(read_text(path));
  } catch (const nlohmann::json::exception& e) {
    throw Error(path + ": not a method state (" + std::string(e.what()) + ")");
  }
  if (j.value("method", "") != name())
    throw Error(path + ": field 'method' is '" + j.value("method", "") + "', this run's method is '" + name() + "'");
  try {
    restore(j, dir);
  } catch (const nlohmann::json::exception& e) {
    throw Error(path + ": " + e.what());
  }
}

std::unique_ptr<Method> act_with(const DiffusionPolicy& policy) { return std::make_unique<PolicyActor>(policy); }

ScoreRule ScoreRule::parse(const std::string& text) {
  ScoreRule r;
  const size_t at = text.find('@');
  r.space = text.substr(0, at);
  try {
    score_space_from(r.space);  // the one list of names
  } catch (const Error& e) {
    throw Error("score rule '" + text + "': " + e.what());
  }
  if (at != std::string::npos) {
    const std::string k = text.substr(at + 1);
    if (k.empty() || k.size() > 4 || k.find_first_not_of("0123456789") != std::string::npos || std::stoi(k) < 1)
      throw Error("score rule '" + text + "': '" + k + "' after @ is not a number of timesteps >= 1");
    r.timesteps = std::stoi(k);
  }
  return r;
}

std::string ScoreRule::name() const { return timesteps > 0 ? space + "@" + std::to_string(timesteps) : space; }

const std::vector<MethodInfo>& method_registry() {
  static const std::vector<MethodInfo> rows = {
      {"diff", "Diff-DAgger", {60, 110, 210}, "expected diffusion loss", "loss", true, false, false},
      {"ensemble", "Ensemble-DAgger", {235, 120, 50}, "ensemble variance", "ensemble variance", true, true, false},
      {"thrifty", "Thrifty-DAgger", {150, 90, 190}, "ensemble variance", "ensemble variance", true, true, true},
      {"bc", "BC", {130, 130, 130}, "", "", false, false, false},
  };
  return rows;
}

const MethodInfo& method_info(const std::string& name) { return find_named(method_registry(), name, "method"); }

std::vector<std::string> method_names() {
  std::vector<std::string> names;
  for (const MethodInfo& m : method_registry()) names.push_back(m.name);
  return names;
}

std::unique_ptr<Method> make_method(const std::string& name, const PolicyConfig& policy, const MethodConfig& config, uint64_t seed) {
  if (name == "diff") return std::make_unique<DiffMethod>(policy, config, seed);
  if (name == "ensemble") return std::make_unique<EnsembleMethod>(policy, config, seed);
  if (name == "thrifty") return std::make_unique<ThriftyMethod>(policy, config, seed);
  if (name == "bc") return std::make_unique<BcMethod>(policy, config, seed);
  method_info(name);  // throws, listing the known names
  throw Error("method '" + name + "' has a registry row and no constructor in make_method");
}

}  // namespace dd
