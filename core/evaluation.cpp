#include "core/evaluation.h"

#include <chrono>
#include <cmath>
#include <map>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "core/gate.h"
#include "core/isolate.h"
#include "core/runtime.h"

namespace dd {

namespace {

// evaluate_rollouts in this process.
std::vector<RolloutResult> rollouts_here(Env& env, Method& method, int episodes, const RolloutSpec& spec, uint64_t seed,
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
    r.compare_first_query_step.assign(n_compare, -1);
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
          if (compare_gates[i].record(d.compare_violations[i]).query && !r.compare_queried[i]) {
            r.compare_queried[i] = 1;
            r.compare_first_query_step[i] = env.steps();
          }
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

}  // namespace

std::vector<RolloutResult> evaluate_rollouts(Env& env, Method& method, int episodes, const RolloutSpec& spec, uint64_t seed,
                                             const ProgressFn& progress, std::vector<RecordedEpisode>* recorded) {
  if (recorded) return rollouts_here(env, method, episodes, spec, seed, progress, recorded);
  std::vector<RolloutResult> out;
  evaluate_rollouts_each(env, method, 0, episodes, spec, seed, [&](int e, const RolloutResult& r) {
    out.push_back(r);
    if (progress) progress(e + 1, episodes, success_rate(out));
  });
  return out;
}

void evaluate_rollouts_each(Env& env, Method& method, int first, int end, const RolloutSpec& spec, uint64_t seed,
                            const std::function<void(int, const RolloutResult&)>& on_result) {
  auto one = [&](int e) { return rollouts_here(env, method, 1, spec, seed + static_cast<uint64_t>(e), {}, nullptr).front(); };
  if (end - first < 2 || !split_in_two_processes()) {
    for (int e = first; e < end; ++e) on_result(e, one(e));
    return;
  }
  // Each child reports "EPISODE JSON" as an episode ends; the parent hands them on in order.
  std::map<int, RolloutResult> ahead;
  int next = first;
  auto job = [&](int j, const ReportFn& report) {
    for (int e = first + j; e < end; e += 2) report(std::to_string(e) + " " + rollout_to_json(one(e)));
    return std::string();
  };
  auto on_report = [&](int, const std::string& message) {
    const size_t space = message.find(' ');
    if (space == std::string::npos) throw Error("rollouts: a child process sent '" + message + "'");
    ahead.emplace(std::stoi(message.substr(0, space)), rollout_from_json(message.substr(space + 1)));
    for (auto it = ahead.find(next); it != ahead.end(); it = ahead.find(next)) {
      on_result(next, it->second);
      ahead.erase(it);
      ++next;
    }
  };
  spdlog::debug("rollouts {} to {} in two child processes", first, end - 1);
  run_in_children(2, 2, "rollouts", job, on_report);
  if (next != end) throw Error("rollouts: the child processes ended after episode " + std::to_string(next) + " of " + std::to_string(end));
}

std::string rollout_to_json(const RolloutResult& r) {
  return nlohmann::json{{"success", r.success},
                        {"queried", r.queried},
                        {"first_query_step", r.first_query_step},
                        {"outcome", r.outcome},
                        {"steps", r.steps},
                        {"decisions", r.decisions},
                        {"inference_s", r.inference_s},
                        {"compare_queried", r.compare_queried},
                        {"compare_first_query_step", r.compare_first_query_step}}
      .dump();
}

RolloutResult rollout_from_json(const std::string& line) {
  try {
    const nlohmann::json j = nlohmann::json::parse(line);
    RolloutResult r;
    r.success = j.at("success").get<bool>();
    r.queried = j.at("queried").get<bool>();
    r.first_query_step = j.at("first_query_step").get<int>();
    r.outcome = j.at("outcome").get<std::string>();
    r.steps = j.at("steps").get<int>();
    r.decisions = j.at("decisions").get<int>();
    r.inference_s = j.at("inference_s").get<double>();
    r.compare_queried = j.at("compare_queried").get<std::vector<uint8_t>>();
    // rollouts written before 2026-12-07 (binaries before d53fc0d) have no such field
    if (j.contains("compare_first_query_step")) r.compare_first_query_step = j.at("compare_first_query_step").get<std::vector<int>>();
    return r;
  } catch (const nlohmann::json::exception& e) {
    throw Error(std::string("not a rollout (") + e.what() + ")");
  }
}

RecordedEpisode expert_episode(Env& env, Expert& expert, uint64_t seed) {
  env.reset(seed);
  expert.reset(seed);
  std::vector<Vec> obs, act;
  ExecutionNoise noise(expert, env.action_dim());
  noise.reset(seed);
  bool done = false;
  while (!done) {
    obs.push_back(env.observation());
    act.push_back(expert.act(env));  // recorded clean, executed with the noise
    const Vec executed = noise.apply(act.back());
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
  return failure_prediction(judged_by(results, rule));
}

std::vector<RolloutResult> judged_by(const std::vector<RolloutResult>& results, size_t rule) {
  std::vector<RolloutResult> judged = results;
  for (RolloutResult& r : judged) {
    if (rule >= r.compare_queried.size()) throw Error("no compared rule " + std::to_string(rule) + " in the rollouts");
    r.queried = r.compare_queried[rule] != 0;
    r.first_query_step = rule < r.compare_first_query_step.size() ? r.compare_first_query_step[rule] : -1;
    r.compare_queried.clear();
    r.compare_first_query_step.clear();
  }
  return judged;
}

double success_rate(const std::vector<RolloutResult>& results) {
  if (results.empty()) return 0.0;
  int s = 0;
  for (const auto& r : results) s += r.success;
  return static_cast<double>(s) / results.size();
}

}  // namespace dd
