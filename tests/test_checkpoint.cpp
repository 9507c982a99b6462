// Checkpoints: a round trip reproduces samples exactly; mismatched, truncated, missing and foreign
// files are rejected with a message that names the file and what is wrong.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <tuple>

#include <nlohmann/json.hpp>

#include "core/chunks.h"
#include "core/nn/archive_io.h"
#include "core/nn/policy_impl.h"
#include "core/policy.h"
#include "core/synthetic.h"
#include "core/trainer.h"
#include "tests/fakes.h"

namespace dd {
namespace {

namespace fs = std::filesystem;

class Checkpoint : public testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("dd_ckpt_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    path_ = (dir_ / "policy.pt").string();
  }
  void TearDown() override { fs::remove_all(dir_); }

  // A policy whose live and EMA weights differ and whose normalisers are fitted.
  static std::unique_ptr<DiffusionPolicy> trained() {
    auto p = std::make_unique<DiffusionPolicy>(fakes::tiny_policy(3, 2), 1);
    TrainConfig t;
    t.steps = 20;
    t.batch_size = 32;
    train(*p, ChunkDataset::from_episodes(bimodal_episodes(6, 10, 3, 2, 4), 8), t);
    return p;
  }

  static std::string message_of(const std::function<void()>& f) {
    try {
      f();
    } catch (const Error& e) {
      return e.what();
    }
    return "(no error)";
  }

  fs::path dir_;
  std::string path_;
};

}  // namespace

TEST_F(Checkpoint, RoundTripGivesIdenticalSamples) {
  const auto original = trained();
  original->save(path_);
  const auto loaded = DiffusionPolicy::from_checkpoint(path_);
  const Vec obs = Vec::LinSpaced(3, -0.5f, 0.5f);
  EXPECT_EQ(original->sample(obs, 42), loaded->sample(obs, 42));
  EXPECT_EQ(original->expected_loss(obs, original->sample(obs, 1), 3),
            loaded->expected_loss(obs, original->sample(obs, 1), 3));
  EXPECT_EQ(original->action_normalizer().scale(), loaded->action_normalizer().scale());

  DiffusionPolicy into(fakes::tiny_policy(3, 2), 99);  // different initial weights
  into.load(path_);
  EXPECT_EQ(original->sample(obs, 7), into.sample(obs, 7));
}

TEST_F(Checkpoint, MismatchedConfigNamesFileAndFields) {
  trained()->save(path_);
  PolicyConfig other = fakes::tiny_policy(3, 2);
  other.unet.down_dims = {16, 32};
  other.obs_dim = 5;
  DiffusionPolicy wrong(other, 0);
  const std::string m = message_of([&] { wrong.load(path_); });
  EXPECT_NE(m.find(path_), std::string::npos) << m;
  EXPECT_NE(m.find("unet.down_dims"), std::string::npos) << m;
  EXPECT_NE(m.find("obs_dim"), std::string::npos) << m;
}

TEST_F(Checkpoint, TruncatedFileIsRejected) {
  trained()->save(path_);
  const auto size = fs::file_size(path_);
  const std::string cut = (dir_ / "cut.pt").string();
  fs::copy_file(path_, cut);
  fs::resize_file(cut, size / 2);
  const std::string m = message_of([&] { DiffusionPolicy::from_checkpoint(cut); });
  EXPECT_NE(m.find(cut), std::string::npos) << m;
  EXPECT_NE(m.find("truncated or corrupt"), std::string::npos) << m;
}

// A checkpoint the fuzzer (tests/fuzz) made: its archive loads, but a weight's view reaches past its
// data, and the first use of the policy threw from inside libtorch. Now loading it is an Error.
TEST_F(Checkpoint, WeightsOutsideTheirDataAreRejected) {
  const std::string path = DD_SOURCE_DIR "/tests/data/fuzz_regressions/checkpoint_view_past_storage.pt";
  const std::string m = message_of([&] { DiffusionPolicy::from_checkpoint(path); });
  EXPECT_NE(m.find(path), std::string::npos) << m;
  EXPECT_NE(m.find("reaches past its data"), std::string::npos) << m;
}

TEST_F(Checkpoint, NonFiniteWeightsAreRejected) {
  const auto p = trained();
  torch::NoGradGuard no_grad;
  p->impl().ema->parameters()[3].view(-1)[0] = std::nanf("");
  p->save(path_);
  const std::string m = message_of([&] { DiffusionPolicy::from_checkpoint(path_); });
  EXPECT_NE(m.find(path_), std::string::npos) << m;
  EXPECT_NE(m.find("NaN or infinite"), std::string::npos) << m;
}

TEST_F(Checkpoint, MissingAndForeignFilesAreRejected) {
  const std::string missing = (dir_ / "nope.pt").string();
  const std::string m = message_of([&] { DiffusionPolicy::from_checkpoint(missing); });
  EXPECT_NE(m.find(missing), std::string::npos) << m;
  EXPECT_NE(m.find("no such"), std::string::npos) << m;

  const std::string text = (dir_ / "notes.txt").string();
  std::ofstream(text) << "not a checkpoint\n";
  EXPECT_NE(message_of([&] { DiffusionPolicy::from_checkpoint(text); }).find(text), std::string::npos);
}

// A file in the checkpoint format whose stored config is `config` and whose weights are `weights`'.
static void write_mixed_checkpoint(const std::string& path, const PolicyConfig& config, const DiffusionPolicy& weights) {
  torch::serialize::OutputArchive archive, model, ema;
  archive.write("format", c10::IValue(std::string("diffdagger-policy")));
  archive.write("version", c10::IValue(int64_t{1}));
  archive.write("config", c10::IValue(nlohmann::json(config).dump()));
  write_normalizers(archive, weights.impl().obs_norm, weights.impl().act_norm);
  weights.impl().model->save(model);
  weights.impl().ema->save(ema);
  archive.write("model", model);
  archive.write("ema", ema);
  archive.save_to(path);
}

TEST(CheckpointConfig, ParameterCountMatchesTheBuiltNetwork) {
  for (const auto& [obs, act, horizon, preset, kernel] :
       {std::tuple{3, 2, 8, "tiny", 5}, std::tuple{24, 7, 32, "cpu", 5}, std::tuple{4, 2, 16, "medium", 3}, std::tuple{5, 3, 8, "tiny", 1}}) {
    PolicyConfig c = fakes::tiny_policy(obs, act);
    c.horizon = horizon;
    c.unet = unet_preset(preset);
    c.unet.kernel_size = kernel;
    for (const std::vector<int>& dims : {c.unet.down_dims, std::vector<int>{c.unet.down_dims.front()}}) {
      c.unet.down_dims = dims;
      const DiffusionPolicy p(c, 0, false);
      int64_t built = 0;
      for (const auto& t : p.impl().model->parameters()) built += t.numel();
      EXPECT_EQ(nn::parameter_count(act, obs, c.unet), built) << preset << " with " << dims.size() << " levels";
    }
  }
}

// A fuzzed checkpoint (tests/fuzz) said kernel_size 99 over weights of kernel 3: Module::load took the
// weights as they were, and sampling read past them. Weights of another shape than the config's
// network are now an Error naming the field, and a policy loaded into keeps its own weights.
TEST_F(Checkpoint, WeightsOfAnotherShapeThanTheConfigsAreRejected) {
  const auto p = trained();
  PolicyConfig wider = p->config();
  wider.unet.kernel_size = 3;  // tiny_policy's kernel is 5
  write_mixed_checkpoint(path_, wider, *p);
  const std::string m = message_of([&] { DiffusionPolicy::from_checkpoint(path_); });
  EXPECT_NE(m.find(path_), std::string::npos) << m;
  EXPECT_NE(m.find("field 'model.down0_res0.block0.conv.weight' is [16, 2, 5] Float where the network its config describes has [16, 2, 3] Float"),
            std::string::npos)
      << m;

  DiffusionPolicy into(wider, 3, false);
  const Vec obs = Vec::LinSpaced(3, -0.5f, 0.5f);
  const Mat before = into.sample(obs, 4);
  EXPECT_NE(message_of([&] { into.load(path_); }).find("where the network its config describes"), std::string::npos);
  EXPECT_EQ(into.sample(obs, 4), before) << "a failed load changed the policy's weights";
}

TEST_F(Checkpoint, ConfigDescribingMoreWeightsThanTheFileHoldsIsRejected) {
  const auto p = trained();
  PolicyConfig huge = p->config();
  huge.unet.down_dims = {4096, 4096};  // about 0.7 G parameters; the file holds a few hundred kB
  write_mixed_checkpoint(path_, huge, *p);
  const std::string m = message_of([&] { DiffusionPolicy::from_checkpoint(path_); });
  EXPECT_NE(m.find(path_ + ": field 'config' describes a network of"), std::string::npos) << m;
  EXPECT_NE(m.find("more than the whole file"), std::string::npos) << m;
}

TEST_F(Checkpoint, FailedSaveLeavesTheOldFileIntact) {
  const auto p = trained();
  p->save(path_);
  const auto before = fs::file_size(path_);
  const std::string bad = (dir_ / "no_such_dir" / "policy.pt").string();
  const std::string m = message_of([&] { p->save(bad); });
  EXPECT_NE(m.find(bad), std::string::npos) << m;
  EXPECT_EQ(fs::file_size(path_), before);
  EXPECT_NO_THROW(DiffusionPolicy::from_checkpoint(path_));
}

TEST_F(Checkpoint, StoppedTrainingResumesAsIfNeverStopped) {
  const ChunkDataset data = ChunkDataset::from_episodes(bimodal_episodes(6, 10, 3, 2, 4), 8);
  TrainConfig t;
  t.steps = 30;
  t.batch_size = 16;
  t.seed = 5;
  DiffusionPolicy straight(fakes::tiny_policy(3, 2), 1);
  std::vector<float> losses;
  {
    Trainer trainer(straight, data, t);
    for (int i = 0; i < 30; ++i) losses.push_back(trainer.step());
  }
  const std::string state = (dir_ / "trainer.pt").string();
  {
    DiffusionPolicy first(fakes::tiny_policy(3, 2), 1);
    Trainer trainer(first, data, t);
    for (int i = 0; i < 12; ++i) trainer.step();
    first.save(path_);
    trainer.save_state(state);
  }
  DiffusionPolicy resumed(fakes::tiny_policy(3, 2), /*seed=*/77);  // other weights until loaded
  resumed.load(path_);
  {
    Trainer trainer(resumed, data, t);
    trainer.resume(state);
    EXPECT_EQ(trainer.steps_done(), 12);
    for (int i = 12; i < 30; ++i) {
      const float expected = losses[static_cast<size_t>(i)];
      EXPECT_NEAR(trainer.step(), expected, 1e-5 * (1 + expected)) << "step " << i;
    }
  }
  const Vec obs = data.obs.row(0).transpose();
  EXPECT_TRUE(straight.sample(obs, 3).isApprox(resumed.sample(obs, 3), 1e-4f)) << "the EMA weights differ";

  // a run of another length, a truncated file and a missing one are refused, naming the file
  TrainConfig longer = t;
  longer.steps = 40;
  DiffusionPolicy other(fakes::tiny_policy(3, 2), 1);
  {
    Trainer wrong(other, data, longer);
    const std::string mismatch = message_of([&] { wrong.resume(state); });
    EXPECT_NE(mismatch.find(state), std::string::npos) << mismatch;
    EXPECT_NE(mismatch.find("total_steps"), std::string::npos) << mismatch;
  }
  fs::resize_file(state, fs::file_size(state) / 2);
  Trainer again(other, data, t);
  const std::string truncated = message_of([&] { again.resume(state); });
  EXPECT_NE(truncated.find(state), std::string::npos) << truncated;
  const std::string missing = message_of([&] { again.resume(state + ".none"); });
  EXPECT_NE(missing.find("no trainer state"), std::string::npos) << missing;
}

}  // namespace dd
