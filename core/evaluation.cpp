#include "core/evaluation.h"

#include <chrono>
#include <cmath>
#include <random>

#include "core/gate.h"

namespace dd {

std::vector<RolloutResult> evaluate_rollouts(Env& env, Method& method, int episodes, const RolloutSpec& spec, uint64_t seed,
                                             const ProgressFn& progress, std::vector<RecordedEpisode>* recorded) {
  std::vector<RolloutResult> out;
  QueryGate gate(0.f, spec.patience);
  const size_t n_compare = method.compare_rules().size();
  std::vector<QueryGate> compare_gates(n_compare, QueryGate(0.f, spec.patience));
  const bool every_step = spec.gate_every == GateCadence::kStep && method.gated();
  for (int e = 0; e < episodes; ++e) {
    RolloutResult r;
    const uint64_t s = seed + static_cast<uint64_t>(e);
    env.reset(s);
    env.set_time_limit(spec.time_limit);
    gate.reset();
    for (QueryGate& g : compare_gates) g.reset();
    r.compare_queried.assign(n_compare, 0);
    bool done = false;
    uint64_t decision = 0;
    Mat chunk;
    int pos = 0;
    std::vector<Vec> obs, act;
    while (!done) {
      const bool need_chunk = chunk.rows() == 0 || pos >= spec.action_steps;
      if (need_chunk || every_step) {
        const auto t = std::chrono::steady_clock::now();
        const MethodDecision d = method.decide(env.observation(), s * 7919 + decision++);
        r.inference_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
        ++r.decisions;
        if (method.gated() && gate.record(d.violation).query && !r.queried) {
          r.queried = true;
          r.first_query_step = env.steps();
        }
        if (d.compare_violations.size() != n_compare)
          throw Error(method.name() + ": a decision judged " + std::to_string(d.compare_violations.size()) + " compared rules, not " +
                      std::to_string(n_compare));
        for (size_t i = 0; i < n_compare; ++i)
          if (compare_gates[i].record(d.compare_violations[i]).query) r.compare_queried[i] = 1;
        if (need_chunk) {
          chunk = d.chunk;
          pos = 0;
        }
      }
      const Vec a = chunk.row(pos++).transpose();
      if (recorded) {
        obs.push_back(env.observation());
        act.push_back(a);
      }
      done = env.step(a).done;
    }
    r.success = env.success();
    r.steps = env.steps();
    r.outcome = env.outcome();
    if (recorded) {
      RecordedEpisode ep;
      ep.obs = stack_rows(obs, env.obs_dim());
      ep.actions = stack_rows(act, env.action_dim());
      ep.success = r.success;
      ep.source = "robot";
      recorded->push_back(std::move(ep));
    }
    out.push_back(r);
    if (progress) progress(e + 1, episodes, success_rate(out));
  }
  return out;
}

RecordedEpisode expert_episode(Env& env, Expert& expert, uint64_t seed) {
  env.reset(seed);
  expert.reset(seed);
  std::vector<Vec> obs, act;
  std::mt19937_64 rng(seed ^ 0xDA27'0000'0000'0001ull);
  std::normal_distribution<float> noise(0.f, 1.f);
  const Vec& sigma = expert.execution_noise;
  if (sigma.size() > 0 && sigma.size() != env.action_dim())
    throw Error(expert.name() + ": execution noise has " + std::to_string(sigma.size()) + " values, the actions " +
                std::to_string(env.action_dim()));
  bool done = false;
  while (!done) {
    obs.push_back(env.observation());
    act.push_back(expert.act(env));
    Vec executed = act.back();  // recorded clean, executed with the noise (none when sigma is empty)
    for (Eigen::Index i = 0; i < sigma.size(); ++i) executed[i] += sigma[i] * noise(rng);
    done = env.step(executed).done;
  }
  RecordedEpisode ep;
  ep.obs = stack_rows(obs, env.obs_dim());
  ep.actions = stack_rows(act, env.action_dim());
  ep.success = env.success();
  ep.intervention.assign(obs.size(), 1);
  ep.rewards.assign(obs.size(), 0.f);
  if (ep.success && !obs.empty()) ep.rewards.back() = 1.f;
  ep.source = "expert";
  return ep;
}

namespace {

template <typename Queried>
FailurePrediction confusion(const std::vector<RolloutResult>& results, Queried queried) {
  FailurePrediction p;
  for (const auto& r : results) {
    const bool failure = !r.success, q = queried(r);
    if (q && failure) ++p.tp;
    else if (q && !failure) ++p.fp;
    else if (!q && !failure) ++p.tn;
    else ++p.fn;
  }
  const int failures = p.tp + p.fn, successes = p.tn + p.fp, n = failures + successes;
  // An empty class leaves its rate undefined (NaN), not 0: no failure to catch is not a miss.
  p.tpr = failures ? static_cast<double>(p.tp) / failures : NAN;
  p.tnr = successes ? static_cast<double>(p.tn) / successes : NAN;
  const int f1_den = 2 * p.tp + p.fp + p.fn;
  p.f1 = f1_den ? 2.0 * p.tp / f1_den : NAN;
  p.accuracy = n ? static_cast<double>(p.tp + p.tn) / n : NAN;
  return p;
}

}  // namespace

FailurePrediction failure_prediction(const std::vector<RolloutResult>& results) {
  return confusion(results, [](const RolloutResult& r) { return r.queried; });
}

FailurePrediction failure_prediction(const std::vector<RolloutResult>& results, size_t rule) {
  return confusion(results, [&](const RolloutResult& r) {
    if (rule >= r.compare_queried.size()) throw Error("failure_prediction: no compared rule " + std::to_string(rule) + " in the rollouts");
    return r.compare_queried[rule] != 0;
  });
}

double success_rate(const std::vector<RolloutResult>& results) {
  if (results.empty()) return 0.0;
  int s = 0;
  for (const auto& r : results) s += r.success;
  return static_cast<double>(s) / results.size();
}

}  // namespace dd
