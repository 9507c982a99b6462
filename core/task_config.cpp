#include "core/task_config.h"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <optional>
#include <nlohmann/json.hpp>
#include <set>

#include "core/json_read.h"
#include "core/policy.h"

namespace dd {
namespace {

using nlohmann::json;

// YAML -> JSON, so that the strict JSON readers of config.cpp check every key.
json to_json(const YAML::Node& n) {
  switch (n.Type()) {
    case YAML::NodeType::Map: {
      json j = json::object();
      for (const auto& kv : n) j[kv.first.as<std::string>()] = to_json(kv.second);
      return j;
    }
    case YAML::NodeType::Sequence: {
      json j = json::array();
      for (const auto& v : n) j.push_back(to_json(v));
      return j;
    }
    case YAML::NodeType::Scalar: {
      const std::string s = n.Scalar();
      if (n.Tag() == "!") return s;  // quoted
      try {
        size_t used = 0;
        const long long i = std::stoll(s, &used);
        if (used == s.size()) return i;
      } catch (...) {
      }
      try {
        size_t used = 0;
        const double d = std::stod(s, &used);
        if (used == s.size()) return d;
      } catch (...) {
      }
      if (s == "true" || s == "True") return true;
      if (s == "false" || s == "False") return false;
      return s;
    }
    default: return nullptr;
  }
}

using json_read::read;

using json_read::require_known_keys;

void apply_dagger(const json& j, DaggerConfig& d) {
  require_known_keys(j, {"initial_demos", "final_demos", "demos_per_update", "patience", "time_limit", "expert_time_limit", "action_steps",
                   "max_episodes", "gate_every", "seed"},
               "dagger");
  read(j, "initial_demos", d.initial_demos, "dagger");
  read(j, "final_demos", d.final_demos, "dagger");
  read(j, "demos_per_update", d.demos_per_update, "dagger");
  read(j, "patience", d.patience, "dagger");
  read(j, "time_limit", d.time_limit, "dagger");
  read(j, "expert_time_limit", d.expert_time_limit, "dagger");
  read(j, "action_steps", d.action_steps, "dagger");
  read(j, "max_episodes", d.max_episodes, "dagger");
  read(j, "seed", d.seed, "dagger");
  if (j.contains("gate_every")) {
    std::string g;
    read(j, "gate_every", g, "dagger");
    if (g != "chunk" && g != "step") throw Error("dagger.gate_every: '" + g + "' is not one of chunk, step");
    d.gate_every = g == "step" ? GateCadence::kStep : GateCadence::kChunk;
  }
}

void apply_method(const json& j, MethodConfig& m) {
  require_known_keys(j, {"alpha", "members", "loss_samples", "calibration_pairs", "screen_threshold", "screen_gate", "score_weights", "risk_quantile",
                         "critic_steps", "precision", "score_space", "score_timesteps", "compare_scores"},
                     "method");
  read(j, "alpha", m.alpha, "method");
  read(j, "members", m.members, "method");
  read(j, "loss_samples", m.loss_samples, "method");
  read(j, "calibration_pairs", m.calibration_pairs, "method");
  read(j, "screen_threshold", m.screen_threshold, "method");
  read(j, "screen_gate", m.screen_gate, "method");
  read(j, "risk_quantile", m.risk_quantile, "method");
  read(j, "critic_steps", m.critic.steps, "method");
  read(j, "score_timesteps", m.score_timesteps, "method");
  if (j.contains("score_weights")) {
    std::string w;
    read(j, "score_weights", w, "method");
    if (w != "ema" && w != "raw") throw Error("method.score_weights: '" + w + "' is not one of ema, raw");
    m.score_raw_weights = w == "raw";
  }
  if (j.contains("score_space")) {
    read(j, "score_space", m.score_space, "method");
    try {
      score_space_from(m.score_space);  // the one list of names
    } catch (const Error& e) {
      throw Error(std::string("method.score_space: ") + e.what());
    }
  }
  if (j.contains("compare_scores")) {
    read(j, "compare_scores", m.compare_scores, "method");
    for (const std::string& r : m.compare_scores) {
      try {
        ScoreRule::parse(r);
      } catch (const Error& e) {
        throw Error(std::string("method.compare_scores: ") + e.what());
      }
    }
  }
  if (j.contains("precision")) {
    read(j, "precision", m.precision, "method");
    try {
      inference_precision_from(m.precision);  // the one list of names
    } catch (const Error& e) {
      throw Error(std::string("method.precision: ") + e.what());
    }
  }
}

json method_json(const MethodConfig& m) {
  return json{{"alpha", m.alpha}, {"members", m.members}, {"loss_samples", m.loss_samples},
              {"calibration_pairs", m.calibration_pairs}, {"screen_threshold", m.screen_threshold},
              {"screen_gate", m.screen_gate},
              {"score_weights", m.score_raw_weights ? "raw" : "ema"}, {"risk_quantile", m.risk_quantile}, {"critic_steps", m.critic.steps},
              {"precision", m.precision}, {"score_space", m.score_space}, {"score_timesteps", m.score_timesteps}, {"compare_scores", m.compare_scores}};
}

json dagger_json(const DaggerConfig& d) {
  return json{{"initial_demos", d.initial_demos}, {"final_demos", d.final_demos}, {"demos_per_update", d.demos_per_update},
              {"patience", d.patience}, {"time_limit", d.time_limit}, {"expert_time_limit", d.expert_time_limit},
              {"action_steps", d.action_steps}, {"max_episodes", d.max_episodes}, {"gate_every", to_string(d.gate_every)}, {"seed", d.seed}};
}

// Table III row: T_p, T_a, T_d, N_i, N_f, N_d, alpha, K, T_L.
ExperimentConfig table3(const std::string& name, const std::string& task, int obs, int act, int tp, int ta, int td, int ni, int nf,
                        int nd, double alpha, int k, int tl) {
  ExperimentConfig c;
  c.preset = name;
  c.task = task;
  c.policy.obs_dim = obs;
  c.policy.action_dim = act;
  c.policy.horizon = tp;
  c.policy.action_steps = ta;
  c.policy.scheduler.num_train_timesteps = td;
  c.policy.scheduler.num_inference_steps = td;
  c.dagger.initial_demos = ni;
  c.dagger.final_demos = nf;
  c.dagger.demos_per_update = nd;
  c.dagger.patience = k;
  c.dagger.time_limit = tl;
  c.dagger.action_steps = ta;
  c.method.alpha = alpha;
  return c;
}

// The paper's Table III row for a preset of one of its tasks, with our state observations' sizes
// (joints, end-effector pose with 6-D rotation, gripper, object poses), if any. The presets start
// from it.
std::optional<ExperimentConfig> paper_row(const std::string& preset) {
  if (preset == "stack") return table3(preset, "stack", 37, 10, 32, 8, 16, 20, 60, 4, 0.99, 2, 250);
  if (preset == "push_1expert") return table3(preset, "push", 24, 7, 32, 2, 16, 20, 100, 4, 0.99, 1, 250);
  if (preset == "push_2experts") return table3(preset, "push", 24, 7, 32, 2, 16, 20, 100, 4, 0.9, 2, 250);
  if (preset == "plug") return table3(preset, "plug", 37, 10, 64, 8, 64, 20, 100, 8, 0.99, 2, 500);
  return std::nullopt;
}

}  // namespace

std::vector<std::string> paper_deviations(const ExperimentConfig& c) {
  const std::optional<ExperimentConfig> paper = paper_row(c.preset);
  if (!paper) return {fmt::format("Task {} (preset {}) is this project's own; the paper gives no schedule for it.", c.task, c.preset)};
  std::vector<std::string> out;
  std::vector<std::string> schedule;
  auto differs = [&](const char* what, auto ours, auto theirs) {
    if (ours != theirs) schedule.push_back(fmt::format("{} {} (paper {})", what, ours, theirs));
  };
  differs("T_p", c.policy.horizon, paper->policy.horizon);
  differs("T_a", c.policy.action_steps, paper->policy.action_steps);
  differs("T_d", c.policy.scheduler.num_train_timesteps, paper->policy.scheduler.num_train_timesteps);
  differs("inference steps", c.policy.scheduler.num_inference_steps, paper->policy.scheduler.num_inference_steps);
  differs("N_i", c.dagger.initial_demos, paper->dagger.initial_demos);
  differs("N_f", c.dagger.final_demos, paper->dagger.final_demos);
  differs("N_d", c.dagger.demos_per_update, paper->dagger.demos_per_update);
  differs("alpha", c.method.alpha, paper->method.alpha);
  differs("K", c.dagger.patience, paper->dagger.patience);
  differs("T_L", c.dagger.time_limit, paper->dagger.time_limit);
  out.push_back(schedule.empty() ? std::string("The schedule is the paper's Table III row for this task.")
                                 : fmt::format("Schedule, against the paper's Table III: {}.", fmt::join(schedule, ", ")));
  const std::vector<int> paper_dims{256, 512, 1024};
  if (c.policy.unet.down_dims != paper_dims)
    out.push_back(fmt::format("Network: a U-Net of down_dims {} (the paper's: 256,512,1024, a GPU size).", fmt::join(c.policy.unet.down_dims, ",")));
  if (!c.train.from_scratch)
    out.push_back(fmt::format("Training: each update continues from the previous weights for {} steps at batch {}; the authors' code "
                              "retrains from scratch for min(300 epochs, 30,000 steps) at batch 64 after new data.",
                              c.train.steps, c.train.batch_size));
  else if (c.train.epochs != 300 || c.train.max_steps != 30000 || c.train.batch_size != 64)
    out.push_back(fmt::format("Training: from scratch for min({} epochs, {} steps) at batch {} (the authors' code: min(300 epochs, "
                              "30,000 steps) at batch 64).",
                              c.train.epochs, c.train.max_steps, c.train.batch_size));
  if (c.dagger.gate_every == GateCadence::kChunk)
    out.push_back("The gate scores once per generated chunk, so K counts chunks; the authors' code scores a fresh chunk at every "
                  "control step (dagger.gate_every: step), a point the paper leaves open.");
  if (!c.method.score_raw_weights)
    out.push_back("The expected loss is scored with the EMA weights that sample; the authors' code scores it with the raw training "
                  "weights (method.score_weights: raw).");
  out.push_back("Observations: the simulator's state (joints, end-effector pose, object poses); the paper's policies see camera images.");
  if (c.task == "push")
    out.push_back(fmt::format("Experts: scripted (mode {}); the paper's were PPO agents.", c.expert));
  if (c.task == "push" && c.dagger.time_limit != paper->dagger.time_limit)
    out.push_back("T_L is scaled to our pushing expert's episode length (about 170 steps, the paper's about 66).");
  return out;
}

void ExperimentConfig::validate() const {
  policy.validate();
  train.validate();
  dagger.validate();
  if (dagger.action_steps != policy.action_steps)
    throw Error("dagger.action_steps (" + std::to_string(dagger.action_steps) + ") must equal policy.action_steps (" +
                std::to_string(policy.action_steps) + ")");
  if (!(method.alpha > 0 && method.alpha < 1)) throw Error("method.alpha: must be in (0, 1)");
  if (method.members < 2) throw Error("method.members: must be >= 2");
  if (method.loss_samples < 1) throw Error("method.loss_samples: must be >= 1");
  if (method.score_timesteps < 0 || method.score_timesteps > policy.scheduler.num_train_timesteps)
    throw Error("method.score_timesteps: " + std::to_string(method.score_timesteps) + " is not between 0 (every timestep) and " +
                "policy.scheduler.num_train_timesteps (" + std::to_string(policy.scheduler.num_train_timesteps) + ")");
  for (const std::string& r : method.compare_scores)
    if (ScoreRule::parse(r).timesteps > policy.scheduler.num_train_timesteps)
      throw Error("method.compare_scores: '" + r + "' draws from more timesteps than policy.scheduler.num_train_timesteps (" +
                  std::to_string(policy.scheduler.num_train_timesteps) + ")");
  if (rq1_demos < 1) throw Error("rq1_demos: must be >= 1");
}

std::vector<std::string> preset_names() { return {"nav2d", "nav2d_random", "stack", "push_1expert", "push_2experts", "plug"}; }

ExperimentConfig preset(const std::string& name) {
  ExperimentConfig c;
  if (name == "nav2d") {
    // Our own toy: small network and budget, chosen so a full evaluation fits in an hour on 2 cores.
    c = table3(name, "nav2d", 4, 2, 16, 8, 16, 8, 24, 4, 0.99, 2, 200);
    c.policy.unet = unet_preset("tiny");
    c.train.steps = 500;
    c.train.batch_size = 128;
    c.train.lr = 1e-3;
    c.train.warmup_steps = 50;
    c.method.loss_samples = 512;
    c.method.critic.steps = 600;
    c.rq1_demos = 3;
    c.dagger.max_episodes = 150;
  } else if (name == "nav2d_random") {
    // The toy with the obstacle moving per episode: few demonstrations do not cover it.
    c = preset("nav2d");
    c.preset = name;
    c.task = "nav2d_random";
    c.policy.obs_dim = 6;
  } else if (name == "stack") {
    // MuJoCo tasks: Table III schedules (paper_row).
    c = *paper_row(name);
    c.expert = "planner";
    // CPU budget: 730 steps at batch 128 per update, so BC on N_f = 60 (11 updates' worth, 8030
    // steps) reaches 0.90 over 100 rollouts (results/bc_curves/stack)
    c.train.steps = 730;
    c.train.batch_size = 128;
    c.rq1_demos = 30;
  } else if (name == "push_1expert") {
    // T_L: the paper's 250 steps for an expert of ~66 steps, scaled to ours of ~170 (envs/mujoco/push.h)
    c = *paper_row(name);
    c.dagger.time_limit = 650;
    // one expert, one sense of rotation; demonstrations recorded with execution noise (DART): BC on
    // N_f = 100 went from 0.67 to 0.97 over 100 rollouts (results/bc_curves/push_1expert)
    c.expert = "cw+noise";
    // CPU budget: 762 steps at batch 128 per update, so BC on N_f (21 updates' worth) trains 16002 steps
    c.train.steps = 762;
    c.train.batch_size = 128;
    // RQ1: BC on 20 demonstrations succeeds in 47% of 100 rollouts (40: 75%; results/bc_curves/push_1expert)
    c.rq1_demos = 20;
  } else if (name == "push_2experts") {
    c = *paper_row(name);
    c.dagger.time_limit = 650;  // as push_1expert's
    c.expert = "alternate+noise";  // two experts: cw and ccw on alternate episodes, with DART noise as above
    c.train.steps = 762;
    c.train.batch_size = 128;
    // RQ1: BC on 50 demonstrations succeeds in 56% of 100 rollouts (results/bc_curves/push_2experts)
    c.rq1_demos = 50;
  } else if (name == "plug") {
    c = *paper_row(name);
    c.expert = "planner";
    // Budget: 1455 steps at batch 128 per update, so BC on N_f = 100 (11 updates' worth) trains 16005
    // steps, about the paper's min(300 epochs, 30,000 steps) at batch 64 for our 8916 pairs. BC there:
    // 0.54 over 100 rollouts (stacking's 8030 steps gave 0.35; results/bc_curves/plug)
    c.train.steps = 1455;
    c.train.batch_size = 128;
    // RQ1 at N_f: BC there succeeds in 54% of rollouts, inside the 30-70% RQ1 wants (fewer not measured)
    c.rq1_demos = 100;
  } else {
    throw Error("unknown preset '" + name + "' (known: nav2d, nav2d_random, stack, push_1expert, push_2experts, plug)");
  }
  return c;
}

ExperimentConfig load_experiment_config(const std::string& path) {
  if (!std::filesystem::exists(path)) throw Error(path + ": no such config file");
  json j;
  try {
    j = to_json(YAML::LoadFile(path));
  } catch (const YAML::Exception& e) {
    throw Error(path + ": malformed YAML: " + e.what());
  }
  try {
    require_known_keys(j, {"preset", "expert", "policy", "train", "dagger", "method", "rq1_demos"}, "config");
    if (!j.contains("preset")) throw Error("config: missing key 'preset' (one of nav2d, stack, push_1expert, push_2experts, plug)");
    ExperimentConfig c = preset(j.at("preset").get<std::string>());
    if (j.contains("policy")) {
      json merged = c.policy;
      merged.merge_patch(j.at("policy"));
      c.policy = merged.get<PolicyConfig>();
    }
    if (j.contains("train")) {
      json merged = c.train;
      merged.merge_patch(j.at("train"));
      c.train = merged.get<TrainConfig>();
    }
    if (j.contains("dagger")) apply_dagger(j.at("dagger"), c.dagger);
    if (j.contains("method")) apply_method(j.at("method"), c.method);
    read(j, "rq1_demos", c.rq1_demos, "config");
    read(j, "expert", c.expert, "config");
    c.validate();
    return c;
  } catch (const Error& e) {
    throw Error(path + ": " + e.what());
  } catch (const json::exception& e) {
    throw Error(path + ": " + e.what());
  }
}

std::string to_json_text(const ExperimentConfig& c) {
  json j{{"preset", c.preset}, {"task", c.task}, {"expert", c.expert}, {"policy", c.policy}, {"train", c.train},
         {"dagger", dagger_json(c.dagger)}, {"method", method_json(c.method)}, {"rq1_demos", c.rq1_demos}};
  return j.dump(2);
}

}  // namespace dd
