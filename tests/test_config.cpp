// Config validation and strict JSON reading.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "core/config.h"

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
}

TEST(PolicyConfig, JsonRoundTrip) {
  PolicyConfig c;
  c.obs_dim = 20;
  c.unet = unet_preset("medium");
  c.scheduler.prediction = PredictionType::kEpsilon;
  c.scheduler.sampler = SamplerType::kDdim;
  const std::string text = nlohmann::json(c).dump();
  const PolicyConfig back = policy_config_from_json(text, "mem");
  EXPECT_TRUE(config_differences(c, back).empty());
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

}  // namespace dd
