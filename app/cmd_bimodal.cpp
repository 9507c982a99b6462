// diffdagger bimodal: the smallest end-to-end run of the core. A synthetic data set whose actions follow
// one of two well-separated modes for the same observation; train, sample, check both modes appear,
// calibrate the query threshold and show that out-of-distribution chunks are flagged.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <filesystem>

#include "app/commands.h"
#include "core/chunks.h"
#include "core/gate.h"
#include "core/policy.h"
#include "core/synthetic.h"
#include "core/trainer.h"

namespace dd::app {

namespace {
struct BimodalOptions {
  std::string out = "out/bimodal";
  std::string preset = "tiny";
  int steps = 600;
  int episodes = 80;
  double alpha = 0.99;
  uint64_t seed = 0;
};

int run_bimodal(const BimodalOptions& o) {
  std::filesystem::create_directories(o.out);
  PolicyConfig pc;
  pc.obs_dim = 2;
  pc.action_dim = 2;
  pc.horizon = 8;
  pc.action_steps = 4;
  pc.unet = unet_preset(o.preset);

  std::vector<int> modes;
  const ChunkDataset data = ChunkDataset::from_episodes(bimodal_episodes(o.episodes, 12, 2, 2, o.seed, 0.05f, &modes), pc.horizon);
  const int plus = static_cast<int>(std::count(modes.begin(), modes.end(), 1));
  fmt::print("data: {} episodes ({} in mode +1, {} in mode -1), {} training pairs\n", o.episodes, plus,
             o.episodes - plus, data.size());

  DiffusionPolicy policy(pc, o.seed);
  TrainConfig tc;
  tc.steps = o.steps;
  tc.batch_size = 128;
  tc.lr = 1e-3;
  tc.warmup_steps = 25;
  tc.seed = o.seed;
  TrainStats stats;
  {
    ProgressBar bar("train", "loss");
    stats = train(policy, data, tc, bar.fn());
  }
  fmt::print("train: {} steps in {:.1f} s, loss {:.4f} -> {:.4f}\n", o.steps, stats.seconds, stats.first_mean(), stats.last_mean());

  const Mat obs = data.obs.row(0).replicate(200, 1);
  int counts[3] = {0, 0, 0};
  for (const Mat& c : policy.sample_batch(obs, o.seed + 1)) counts[bimodal_mode(c) + 1]++;
  fmt::print("sample: 200 chunks at one observation: {} mode +1, {} mode -1, {} in between\n", counts[2], counts[0], counts[1]);

  std::vector<float> losses;
  {
    ProgressBar bar("calibrate", "loss");
    losses = policy.expected_losses(data, o.seed + 2, 128, bar.fn());
  }
  const float threshold = quantile(losses, o.alpha);
  int flagged_ood = 0, flagged_id = 0;
  const int probes = 50;
  for (int i = 0; i < probes; ++i) {
    const int k = (i * 37) % data.size();
    const Vec ob = data.obs.row(k).transpose();
    flagged_id += policy.expected_loss(ob, data.chunk(k), i) > threshold;
    flagged_ood += policy.expected_loss(ob, Mat(data.chunk(k).array() + 3.0f), i) > threshold;
  }
  fmt::print("gate: threshold (alpha {}) = {:.4f}; above it: {}/{} training chunks, {}/{} chunks shifted out of distribution\n",
             o.alpha, threshold, flagged_id, probes, flagged_ood, probes);
  const std::string ckpt = o.out + "/policy.pt";
  policy.save(ckpt);
  fmt::print("saved {}\n", ckpt);
  return (counts[0] > 0 && counts[2] > 0) ? 0 : 1;
}
}  // namespace

Command add_bimodal(CLI::App& app) {
  auto* cmd = app.add_subcommand("bimodal", "Train and sample a small policy on a synthetic two-mode data set");
  auto o = std::make_shared<BimodalOptions>();
  cmd->add_option("--out", o->out, "output folder")->capture_default_str();
  cmd->add_option("--preset", o->preset, "network size: tiny, cpu, medium, paper")->capture_default_str();
  cmd->add_option("--steps", o->steps, "training steps")->capture_default_str()->check(CLI::PositiveNumber);
  cmd->add_option("--episodes", o->episodes, "synthetic episodes")->capture_default_str()->check(CLI::PositiveNumber);
  cmd->add_option("--alpha", o->alpha, "quantile for the query threshold")->capture_default_str()->check(CLI::Range(0.0, 1.0));
  cmd->add_option("--seed", o->seed, "random seed")->capture_default_str();
  return [o] { return run_bimodal(*o); };
}

}  // namespace dd::app
