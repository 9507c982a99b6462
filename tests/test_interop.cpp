// diffusion_policy interop: a state_dict built from our own network's weights under
// diffusion_policy's names imports into a policy that samples the same chunks; the file Python's
// torch.save would write (tests/diffusion_policy_interop.py) does too; and every malformed input is
// rejected with a message naming the file and the key or field.
#include <gtest/gtest.h>
#include <torch/torch.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>

#include <nlohmann/json.hpp>

#include "core/chunks.h"
#include "core/interop.h"
#include "core/policy.h"
#include "core/synthetic.h"
#include "core/text_file.h"
#include "core/trainer.h"
#include "tests/fakes.h"

namespace dd {
namespace {

namespace fs = std::filesystem;
using Dict = c10::Dict<std::string, torch::Tensor>;

class Interop : public testing::Test {
 protected:
  static void SetUpTestSuite() {
    // A policy whose live and EMA weights differ (the EMA samples) and whose normalisers are fitted.
    PolicyConfig c = fakes::tiny_policy(3, 2);
    c.scheduler.prediction = PredictionType::kEpsilon;
    policy_ = std::make_unique<DiffusionPolicy>(c, 1);
    TrainConfig t;
    t.steps = 20;
    t.batch_size = 32;
    train(*policy_, ChunkDataset::from_episodes(bimodal_episodes(6, 10, 3, 2, 4), 8), t);
  }
  static void TearDownTestSuite() { policy_.reset(); }
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("dd_interop_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    sd_ = (dir_ / "unet.pt").string();
    json_ = (dir_ / "unet.json").string();
    export_diffusion_policy(*policy_, sd_, json_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::unique_ptr<DiffusionPolicy> import(const std::string& sd, const std::string& json) const {
    return import_diffusion_policy(sd, json, policy_->config());
  }
  static Dict read_dict(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    const std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    return c10::impl::toTypedDict<std::string, torch::Tensor>(torch::pickle_load(bytes).toGenericDict());
  }
  static void write_value(const std::string& path, const c10::IValue& v) {
    const std::vector<char> bytes = torch::pickle_save(v);
    std::ofstream(path, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  }
  // The exported dict changed by `edit`, written to a new file; its path.
  std::string edited(const std::function<void(Dict&)>& edit) const {
    Dict d = read_dict(sd_);
    edit(d);
    const std::string path = (dir_ / "edited.pt").string();
    write_value(path, d);
    return path;
  }
  std::string edited_json(const std::function<void(nlohmann::json&)>& edit) const {
    nlohmann::json j = nlohmann::json::parse(read_text(json_));
    edit(j);
    const std::string path = (dir_ / "edited.json").string();
    write_text(path, j.dump());
    return path;
  }
  std::string message_of(const std::string& sd, const std::string& json) const {
    try {
      import(sd, json);
    } catch (const Error& e) {
      return e.what();
    }
    return "(no error)";
  }
  static void expect_same_policy(const DiffusionPolicy& a, const DiffusionPolicy& b) {
    for (const float x : {-0.7f, 0.1f, 0.9f}) {
      const Vec obs = Vec::Constant(3, x);
      const Mat ca = a.sample(obs, 42), cb = b.sample(obs, 42);
      EXPECT_LT((ca - cb).cwiseAbs().maxCoeff(), 1e-5f) << "obs " << x;
      EXPECT_NEAR(a.expected_loss(obs, ca, 3), b.expected_loss(obs, ca, 3), 1e-5f);
    }
  }

  static std::unique_ptr<DiffusionPolicy> policy_;
  fs::path dir_;
  std::string sd_, json_;
};
std::unique_ptr<DiffusionPolicy> Interop::policy_;

}  // namespace

TEST_F(Interop, ImportedPolicySamplesTheSameChunks) {
  const auto imported = import(sd_, json_);
  const PolicyConfig& c = imported->config();
  EXPECT_EQ(c.unet.down_dims, policy_->config().unet.down_dims);  // read from the weights
  EXPECT_EQ(c.unet.kernel_size, policy_->config().unet.kernel_size);
  EXPECT_EQ(c.unet.step_embed_dim, policy_->config().unet.step_embed_dim);
  EXPECT_EQ(c.scheduler.prediction, PredictionType::kEpsilon);
  EXPECT_EQ(imported->num_parameters(), policy_->num_parameters());
  expect_same_policy(*policy_, *imported);
  // and the imported checkpoint is an ordinary one
  const std::string ckpt = (dir_ / "imported.pt").string();
  imported->save(ckpt);
  expect_same_policy(*policy_, *DiffusionPolicy::from_checkpoint(ckpt));
}

TEST_F(Interop, FileInPythonTorchSaveLayoutImports) {
  if (!fs::exists("/usr/bin/python3")) GTEST_SKIP() << "no /usr/bin/python3";
  const std::string py = (dir_ / "python_style.pt").string();
  const std::string cmd = "/usr/bin/python3 " DD_SOURCE_DIR "/tests/diffusion_policy_interop.py " + sd_ + " " + json_ + " " + py;
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;  // also checks names and shapes against ConditionalUnet1D's
  expect_same_policy(*policy_, *import(py, json_));
}

TEST_F(Interop, WholePolicyStateDictWithItsNormalizer) {
  // policy.state_dict(): the network under `model.`, the normalizer beside it; the JSON has no normalizer
  const auto reference = import(sd_, json_);
  const std::string sd = edited([&](Dict& d) {
    Dict prefixed;
    for (const auto& e : d) prefixed.insert("model." + e.key(), e.value());
    auto vec = [](const Vec& v) { return torch::from_blob(const_cast<float*>(v.data()), {v.size()}).clone(); };
    prefixed.insert("normalizer.params_dict.obs.scale", vec(reference->obs_normalizer().scale()));
    prefixed.insert("normalizer.params_dict.obs.offset", vec(reference->obs_normalizer().offset()));
    prefixed.insert("normalizer.params_dict.action.scale", vec(reference->action_normalizer().scale()));
    prefixed.insert("normalizer.params_dict.action.offset", vec(reference->action_normalizer().offset()));
    prefixed.insert("normalizer.params_dict.obs.input_stats.min", torch::zeros({3}));
    d = prefixed;
  });
  const std::string json = edited_json([](nlohmann::json& j) {
    j.erase("obs");
    j.erase("action");
  });
  expect_same_policy(*policy_, *import(sd, json));
}

TEST_F(Interop, MalformedInputNamesFileAndKey) {
  auto has = [](const std::string& m, std::initializer_list<std::string> parts) {
    for (const std::string& p : parts)
      if (m.find(p) == std::string::npos) return testing::AssertionFailure() << "'" << p << "' not in: " << m;
    return testing::AssertionSuccess();
  };
  const std::string key = "down_modules.1.0.blocks.1.block.0.weight";
  std::string sd = edited([&](Dict& d) { ASSERT_EQ(d.erase(key), 1u); });
  EXPECT_TRUE(has(message_of(sd, json_), {sd, "missing key", key}));

  sd = edited([&](Dict& d) { d.insert_or_assign(key, torch::zeros({3, 3, 3})); });
  EXPECT_TRUE(has(message_of(sd, json_), {sd, key, "[3, 3, 3]"}));

  sd = edited([&](Dict& d) { d.insert("local_cond_encoder.0.blocks.0.block.0.weight", torch::zeros({2})); });
  EXPECT_TRUE(has(message_of(sd, json_), {sd, "local_cond_encoder.0"}));

  sd = edited([&](Dict& d) { d.at("final_conv.1.bias")[0] = std::nanf(""); });
  EXPECT_TRUE(has(message_of(sd, json_), {sd, "final_conv.1.bias", "NaN"}));

  sd = edited([&](Dict& d) {  // cond_predict_scale=False: the FiLM Linear predicts a bias only
    const torch::Tensor w = d.at("down_modules.0.0.cond_encoder.1.weight");
    d.insert_or_assign("down_modules.0.0.cond_encoder.1.weight", w.narrow(0, 0, w.size(0) / 2).clone());
  });
  EXPECT_TRUE(has(message_of(sd, json_), {sd, "cond_predict_scale"}));

  const std::string tensor_file = (dir_ / "tensor.pt").string();
  write_value(tensor_file, torch::zeros({2}));
  EXPECT_TRUE(has(message_of(tensor_file, json_), {tensor_file, "not a dict"}));

  const std::string garbage = (dir_ / "garbage.pt").string();
  write_text(garbage, "PK\x03\x04 not really a zip");
  EXPECT_TRUE(has(message_of(garbage, json_), {garbage, "not a state_dict"}));
  EXPECT_TRUE(has(message_of((dir_ / "absent.pt").string(), json_), {"absent.pt", "cannot open"}));

  std::string json = edited_json([](nlohmann::json& j) { j.erase("horizon"); });
  EXPECT_TRUE(has(message_of(sd_, json), {json, "'horizon'"}));
  json = edited_json([](nlohmann::json& j) { j["n_obs_steps"] = 2; });
  EXPECT_TRUE(has(message_of(sd_, json), {json, "'n_obs_steps'"}));
  json = edited_json([](nlohmann::json& j) { j["obs"]["scale"] = {1.0, 2.0}; });
  EXPECT_TRUE(has(message_of(sd_, json), {json, "'obs'"}));
  json = edited_json([](nlohmann::json& j) { j["prediction_type"] = "noise"; });
  EXPECT_TRUE(has(message_of(sd_, json), {json, "'prediction_type'"}));
  json = edited_json([](nlohmann::json& j) { j["horizon"] = "sixteen"; });
  EXPECT_TRUE(has(message_of(sd_, json), {json, "'horizon'"}));
  json = edited_json([](nlohmann::json& j) { j["down_dims"] = {8, 16}; });
  EXPECT_TRUE(has(message_of(sd_, json), {json, "'down_dims'"}));
  write_text(json_, "{ not json");
  EXPECT_TRUE(has(message_of(sd_, json_), {json_, "not valid JSON"}));
}

// A file the fuzzer (tests/fuzz) made libtorch's zip reader overflow its heap on: an Error naming it.
TEST_F(Interop, AFileThatCrashedLibtorchIsAnError) {
  const std::string path = DD_SOURCE_DIR "/tests/data/fuzz_regressions/torch_zip_central_directory_overflow.pt";
  const std::string m = message_of(path, json_);
  EXPECT_NE(m.find(path), std::string::npos) << m;
  expect_same_policy(*policy_, *import(sd_, json_));  // and this process goes on
}

TEST_F(Interop, TaskOfOtherSizesIsRefused) {
  PolicyConfig other = policy_->config();
  other.obs_dim = 5;
  try {
    import_diffusion_policy(sd_, json_, other);
    FAIL() << "imported into a task with 5 observation features";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("this task has 5"), std::string::npos) << e.what();
  }
}

}  // namespace dd
