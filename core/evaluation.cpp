#include "core/evaluation.h"

#include <chrono>

#include "core/gate.h"

namespace dd {

std::vector<RolloutResult> evaluate_rollouts(Env& env, Method& method, int episodes, int time_limit, int patience,
                                             int action_steps, uint64_t seed, const ProgressFn& progress,
                                             std::vector<RecordedEpisode>* recorded) {
  std::vector<RolloutResult> out;
  QueryGate gate(0.f, patience);
  for (int e = 0; e < episodes; ++e) {
    RolloutResult r;
    const uint64_t s = seed + static_cast<uint64_t>(e);
    env.reset(s);
    env.set_time_limit(time_limit);
    gate.reset();
    bool done = false;
    uint64_t decision = 0;
    std::vector<Vec> obs, act;
    while (!done) {
      const auto t = std::chrono::steady_clock::now();
      const MethodDecision d = method.decide(env.observation(), s * 7919 + decision++);
      r.inference_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
      ++r.decisions;
      if (method.gated() && gate.record(d.violation).query && !r.queried) {
        r.queried = true;
        r.first_query_step = env.steps();
      }
      for (int k = 0; k < action_steps && !done; ++k) {
        if (recorded) {
          obs.push_back(env.observation());
          act.push_back(d.chunk.row(k).transpose());
        }
        done = env.step(d.chunk.row(k).transpose()).done;
      }
    }
    r.success = env.success();
    r.steps = env.steps();
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
  bool done = false;
  while (!done) {
    obs.push_back(env.observation());
    act.push_back(expert.act(env));
    done = env.step(act.back()).done;
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

FailurePrediction failure_prediction(const std::vector<RolloutResult>& results) {
  FailurePrediction p;
  for (const auto& r : results) {
    const bool failure = !r.success;
    if (r.queried && failure) ++p.tp;
    else if (r.queried && !failure) ++p.fp;
    else if (!r.queried && !failure) ++p.tn;
    else ++p.fn;
  }
  const int failures = p.tp + p.fn, successes = p.tn + p.fp, n = failures + successes;
  p.tpr = failures ? static_cast<double>(p.tp) / failures : 0.0;
  p.tnr = successes ? static_cast<double>(p.tn) / successes : 0.0;
  const double precision = (p.tp + p.fp) ? static_cast<double>(p.tp) / (p.tp + p.fp) : 0.0;
  p.f1 = (precision + p.tpr) > 0 ? 2 * precision * p.tpr / (precision + p.tpr) : 0.0;
  p.accuracy = n ? static_cast<double>(p.tp + p.tn) / n : 0.0;
  return p;
}

double success_rate(const std::vector<RolloutResult>& results) {
  if (results.empty()) return 0.0;
  int s = 0;
  for (const auto& r : results) s += r.success;
  return static_cast<double>(s) / results.size();
}

}  // namespace dd
