// Config validation and strict JSON reading.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <filesystem>
#include <functional>
#include <fstream>

#include "core/config.h"
#include "core/task_config.h"

namespace dd {

TEST(PolicyConfig, DefaultsAreValidAndPresetsExist) {
  PolicyConfig c;
  EXPECT_NO_THROW(c.validate());
  EXPECT_EQ(unet_preset("paper").down_dims, (std::vector<int>{256, 512, 1024}));
  EXPECT_EQ(unet_preset("medium").down_dims, (std::vector<int>{64, 128, 256}));
  EXPECT_THROW(unet_preset("huge"), Error);
}

TEST(PolicyConfig, ValidationNamesTheField) {
  PolicyConfig c;
  c.horizon = 10;  // not divisible by 4 with three levels
  try {
    c.validate();
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("horizon"), std::string::npos) << e.what();
  }
  c = PolicyConfig{};
  c.unet.down_dims = {30, 64, 128};
  EXPECT_THROW(c.validate(), Error);
  c = PolicyConfig{};
  c.scheduler.num_inference_steps = 100;
  EXPECT_THROW(c.validate(), Error);
  for (const auto& pairs : {std::vector<std::array<int, 2>>{{2, 0}}, {{0, 4}}, {{0, 1}, {0, 2}}}) {
    c = PolicyConfig{};  // action_dim 2, obs_dim 4: out of range, and an action index twice
    c.relative_actions = pairs;
    try {
      c.validate();
      ADD_FAILURE() << "expected an error";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("relative_actions"), std::string::npos) << e.what();
    }
  }
}

// Values a corrupt checkpoint's config held (tests/fuzz): each was undefined behaviour in validate()
// itself (a division by zero groups, a shift by 40 levels) or a network of terabytes. Each is now an
// Error naming its field.
TEST(PolicyConfig, OutOfRangeSizesAreErrorsNamingTheField) {
  struct Case {
    const char* field;
    std::function<void(PolicyConfig&)> set;
  };
  const std::vector<Case> cases{
      {"unet.n_groups", [](PolicyConfig& c) { c.unet.n_groups = 0; }},
      {"unet.n_groups", [](PolicyConfig& c) { c.unet.n_groups = -4; }},
      {"unet.down_dims", [](PolicyConfig& c) { c.unet.down_dims.assign(40, 8); }},
      {"unet.down_dims", [](PolicyConfig& c) { c.unet.down_dims = {400000, 400000}; }},
      {"unet.kernel_size", [](PolicyConfig& c) { c.unet.kernel_size = 2000000001; }},
      {"unet.step_embed_dim", [](PolicyConfig& c) { c.unet.step_embed_dim = 2000000000; }},
      {"obs_dim", [](PolicyConfig& c) { c.obs_dim = 2000000000; }},
      {"action_dim", [](PolicyConfig& c) { c.action_dim = 2000000000; }},
      {"horizon", [](PolicyConfig& c) { c.horizon = 1 << 30; }},
  };
  for (const Case& k : cases) {
    PolicyConfig c;
    k.set(c);
    try {
      c.validate();
      ADD_FAILURE() << k.field << ": expected an error";
    } catch (const Error& e) {
      EXPECT_EQ(std::string(e.what()).rfind(k.field, 0), 0u) << e.what();
    }
  }
  PolicyConfig paper;  // the paper's network stays well inside the bounds
  paper.unet = unet_preset("paper");
  EXPECT_NO_THROW(paper.validate());
}

TEST(PolicyConfig, JsonRoundTrip) {
  PolicyConfig c;
  c.obs_dim = 20;
  c.unet = unet_preset("medium");
  c.scheduler.prediction = PredictionType::kEpsilon;
  c.scheduler.sampler = SamplerType::kDdim;
  c.relative_actions = {{0, 2}, {1, 3}};
  const std::string text = nlohmann::json(c).dump();
  const PolicyConfig back = policy_config_from_json(text, "mem");
  EXPECT_TRUE(config_differences(c, back).empty());
  EXPECT_EQ(back.relative_actions, c.relative_actions);
  // a config written before relative_actions existed reads as absolute actions
  nlohmann::json old = nlohmann::json(PolicyConfig{});
  old.erase("relative_actions");
  EXPECT_TRUE(policy_config_from_json(old.dump(), "old").relative_actions.empty());
  EXPECT_EQ(back.scheduler.prediction, PredictionType::kEpsilon);
}

TEST(PolicyConfig, UnknownKeyIsAnErrorNamingFileAndKey) {
  try {
    policy_config_from_json(R"({"obs_dim": 3, "unet": {"down_dim": [8, 16]}})", "cfg.json");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("cfg.json"), std::string::npos) << m;
    EXPECT_NE(m.find("down_dim"), std::string::npos) << m;
  }
  EXPECT_THROW(policy_config_from_json("{not json", "cfg.json"), Error);
  EXPECT_THROW(policy_config_from_json(R"({"obs_dim": "three"})", "cfg.json"), Error);
  EXPECT_THROW(policy_config_from_json(R"({"scheduler": {"prediction": "noise"}})", "cfg.json"), Error);
}

TEST(PolicyConfig, DifferencesNameTheFields) {
  PolicyConfig a, b;
  b.unet.down_dims = {16, 32};
  b.obs_dim = 7;
  const auto d = config_differences(a, b);
  ASSERT_EQ(d.size(), 2u);
  std::string all;
  for (const auto& s : d) all += s + "\n";
  EXPECT_NE(all.find("unet.down_dims: [32,64,128] vs [16,32]"), std::string::npos) << all;
  EXPECT_NE(all.find("obs_dim: 4 vs 7"), std::string::npos) << all;
}

TEST(TrainConfig, RejectsUnknownKeysAndBadValues) {
  TrainConfig t;
  EXPECT_THROW(nlohmann::json({{"stpes", 3}}).get_to(t), Error);
  t.lr = -1;
  EXPECT_THROW(t.validate(), Error);
}

TEST(TrainConfig, TheEpochRuleSetsTheStepsAndIsCapped) {
  TrainConfig t;
  t.steps = 123;
  EXPECT_EQ(t.steps_for(1000), 123);  // epochs 0: the fixed budget
  t.epochs = 10;
  t.batch_size = 64;
  EXPECT_EQ(t.steps_for(1000), 157);  // ceil(10 * 1000 / 64)
  t.max_steps = 100;
  EXPECT_EQ(t.steps_for(1000), 100);
}

namespace {
std::string write_config(const std::string& name, const std::string& text) {
  const std::string path = (std::filesystem::temp_directory_path() / name).string();
  std::ofstream(path) << text;
  return path;
}
}  // namespace

TEST(ExperimentConfig, ThePresetsNameTheirExperts) {
  EXPECT_EQ(preset("push_1expert").expert, "cw+noise");
  EXPECT_EQ(preset("push_2experts").expert, "alternate+noise");
  EXPECT_EQ(preset("stack").expert, "planner");
  EXPECT_EQ(preset("nav2d").expert, "mixed");
  EXPECT_EQ(preset("stack").method.calibration_pairs, 0);  // thresholds over every training pair
}

// Does any line contain `part`?
bool mentions(const std::vector<std::string>& lines, const std::string& part) {
  for (const std::string& l : lines)
    if (l.find(part) != std::string::npos) return true;
  return false;
}

TEST(ExperimentConfig, DeviationsFromThePaperAreListed) {
  // stacking keeps Table III's schedule; the network, training and observations differ
  std::vector<std::string> d = paper_deviations(preset("stack"));
  EXPECT_TRUE(mentions(d, "is the paper's Table III row")) << d.front();
  EXPECT_TRUE(mentions(d, "down_dims 32,64,128"));
  EXPECT_TRUE(mentions(d, "730 steps at batch 128"));
  EXPECT_TRUE(mentions(d, "camera images"));
  EXPECT_TRUE(mentions(d, "once per generated chunk"));
  // a changed schedule value is named with the paper's
  ExperimentConfig c = preset("stack");
  c.method.alpha = 0.9;
  c.dagger.final_demos = 40;
  d = paper_deviations(c);
  EXPECT_TRUE(mentions(d, "N_f 40 (paper 60), alpha 0.9 (paper 0.99)")) << d.front();
  EXPECT_FALSE(mentions(d, "is the paper's Table III row"));
  c.dagger.gate_every = GateCadence::kStep;  // as the authors' code
  EXPECT_FALSE(mentions(paper_deviations(c), "once per generated chunk"));
  // pushing: our time limit and scripted experts
  d = paper_deviations(preset("push_2experts"));
  EXPECT_TRUE(mentions(d, "T_L 650 (paper 250)"));
  EXPECT_TRUE(mentions(d, "PPO"));
  EXPECT_FALSE(mentions(d, "alpha"));  // Table III has 0.9 for two experts, as the preset
  // the toys have no schedule in the paper
  d = paper_deviations(preset("nav2d"));
  ASSERT_EQ(d.size(), 1u);
  EXPECT_TRUE(mentions(d, "gives no schedule"));
}

TEST(ExperimentConfig, ProtocolOptionsReadFromAFile) {
  const std::string path = write_config("dd_protocol_options.yaml", R"(preset: push_2experts
expert: ccw
train: {from_scratch: true, epochs: 300, max_steps: 5000}
dagger: {gate_every: step}
method: {score_weights: raw, calibration_pairs: 500, score_space: epsilon, score_timesteps: 4, compare_scores: [target, "v@2"]}
)");
  const ExperimentConfig c = load_experiment_config(path);
  EXPECT_EQ(c.expert, "ccw");
  EXPECT_TRUE(c.train.from_scratch);
  EXPECT_EQ(c.train.epochs, 300);
  EXPECT_EQ(c.train.max_steps, 5000);
  EXPECT_EQ(c.dagger.gate_every, GateCadence::kStep);
  EXPECT_TRUE(c.method.score_raw_weights);
  EXPECT_EQ(c.method.calibration_pairs, 500);
  EXPECT_EQ(c.method.score_space, "epsilon");
  EXPECT_EQ(c.method.score_timesteps, 4);
  EXPECT_EQ(c.method.compare_scores, (std::vector<std::string>{"target", "v@2"}));
  // and they round-trip through the JSON every run writes beside its results
  EXPECT_NE(to_json_text(c).find("\"gate_every\": \"step\""), std::string::npos);
  EXPECT_NE(to_json_text(c).find("\"score_weights\": \"raw\""), std::string::npos);
  std::filesystem::remove(path);
}

TEST(ExperimentConfig, BadProtocolOptionsNameTheFileAndKey) {
  for (const auto& [text, key] : std::vector<std::pair<std::string, std::string>>{
           {"preset: stack\ndagger: {gate_every: episode}\n", "dagger.gate_every"},
           {"preset: stack\nmethod: {score_weights: best}\n", "method.score_weights"},
           {"preset: stack\nmethod: {precision: float16}\n", "method.precision"},
           {"preset: stack\nmethod: {score_space: x0}\n", "method.score_space"},
           {"preset: stack\nmethod: {score_timesteps: 17}\n", "method.score_timesteps"},
           {"preset: stack\nmethod: {score_timesteps: -1}\n", "method.score_timesteps"},
           {"preset: stack\nmethod: {compare_scores: [x0]}\n", "method.compare_scores"},
           {"preset: stack\nmethod: {compare_scores: [\"target@17\"]}\n", "method.compare_scores"},
           {"preset: stack\nmethod: {compare_scores: epsilon}\n", "method.compare_scores"},
           {"preset: stack\ntrain: {epochs: -1}\n", "train.epochs"},
           // numbers that do not fit their integer (tests/fuzz: converting them was undefined behaviour)
           {"preset: stack\ndagger: {patience: 1e20}\n", "dagger.patience"},
           {"preset: stack\ndagger: {patience: 2.5}\n", "dagger.patience"},
           {"preset: stack\ndagger: {time_limit: 99999999999999999999}\n", "dagger.time_limit"},
           {"preset: plug\npolicy: {relative_actions: [[0, 7222222222222222222222]]}\n", "relative_actions"}}) {
    const std::string path = write_config("dd_bad_protocol.yaml", text);
    try {
      load_experiment_config(path);
      ADD_FAILURE() << "accepted: " << text;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
    std::filesystem::remove(path);
  }
}

}  // namespace dd
