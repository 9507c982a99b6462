#include "core/critic.h"

#include <torch/torch.h>

#include <filesystem>

#include "core/config.h"
#include "core/nn/archive_io.h"
#include "core/normalizer.h"

namespace dd {
namespace {

torch::nn::Sequential make_mlp(int in, int hidden) {
  return torch::nn::Sequential(torch::nn::Linear(in, hidden), torch::nn::ReLU(), torch::nn::Linear(hidden, hidden),
                               torch::nn::ReLU(), torch::nn::Linear(hidden, 1), torch::nn::Sigmoid());
}

torch::Tensor to_tensor(const Mat& m) {
  return torch::from_blob(const_cast<float*>(m.data()), {m.rows(), m.cols()}, torch::kFloat32).clone();
}

}  // namespace

struct RiskCritic::Impl {
  CriticConfig config;
  int obs_dim, action_dim;
  torch::nn::Sequential q1, q2, t1, t2;  // twins and their targets
  Normalizer obs_norm, act_norm;

  torch::Tensor inputs(const Mat& obs, const Mat& act) const {
    return torch::cat({to_tensor(obs_norm.normalize(obs)), to_tensor(act_norm.normalize(act))}, 1);
  }
};

RiskCritic::RiskCritic(int obs_dim, int action_dim, const CriticConfig& config) : impl_(std::make_unique<Impl>()) {
  impl_->config = config;
  impl_->obs_dim = obs_dim;
  impl_->action_dim = action_dim;
  impl_->obs_norm = Normalizer(obs_dim);
  impl_->act_norm = Normalizer(action_dim);
  torch::manual_seed(config.seed);
  impl_->q1 = make_mlp(obs_dim + action_dim, config.hidden);
  impl_->q2 = make_mlp(obs_dim + action_dim, config.hidden);
  impl_->t1 = make_mlp(obs_dim + action_dim, config.hidden);
  impl_->t2 = make_mlp(obs_dim + action_dim, config.hidden);
}

RiskCritic::~RiskCritic() = default;
RiskCritic::RiskCritic(RiskCritic&&) noexcept = default;
RiskCritic& RiskCritic::operator=(RiskCritic&&) noexcept = default;

float RiskCritic::train(const std::vector<RecordedEpisode>& episodes, const ProgressFn& progress) {
  Impl& m = *impl_;
  // Transitions (o, a, r, o', a', done).
  Eigen::Index n = 0;
  for (const auto& e : episodes) n += e.steps();
  if (n == 0) throw Error("critic: no transitions to train on");
  Mat obs(n, m.obs_dim), act(n, m.action_dim), next_obs(n, m.obs_dim), next_act(n, m.action_dim);
  std::vector<float> reward(static_cast<size_t>(n)), done(static_cast<size_t>(n));
  Eigen::Index row = 0;
  for (const auto& e : episodes) {
    for (int t = 0; t < e.steps(); ++t, ++row) {
      const int t1 = std::min(t + 1, e.steps() - 1);
      obs.row(row) = e.obs.row(t);
      act.row(row) = e.actions.row(t);
      next_obs.row(row) = e.obs.row(t1);
      next_act.row(row) = e.actions.row(t1);
      const bool last = t == e.steps() - 1;
      reward[static_cast<size_t>(row)] = (last && e.success) ? 1.f : (e.rewards.empty() ? 0.f : e.rewards[static_cast<size_t>(t)]);
      done[static_cast<size_t>(row)] = last || (!e.dones.empty() && e.dones[static_cast<size_t>(t)]) ? 1.f : 0.f;
    }
  }
  m.obs_norm = Normalizer::fit(obs);
  m.act_norm = Normalizer::fit(act);
  const torch::Tensor x = m.inputs(obs, act), x_next = m.inputs(next_obs, next_act);
  const torch::Tensor r = torch::tensor(reward).view({-1, 1}), d = torch::tensor(done).view({-1, 1});

  std::vector<torch::Tensor> params = m.q1->parameters();
  for (auto& p : m.q2->parameters()) params.push_back(p);
  torch::optim::Adam opt(params, torch::optim::AdamOptions(m.config.lr));
  {
    torch::NoGradGuard g;
    auto copy = [](torch::nn::Sequential& dst, torch::nn::Sequential& src) {
      auto a = dst->parameters(), b = src->parameters();
      for (size_t i = 0; i < a.size(); ++i) a[i].copy_(b[i]);
    };
    copy(m.t1, m.q1);
    copy(m.t2, m.q2);
  }
  torch::Generator gen = at::detail::createCPUGenerator(m.config.seed);
  float last = 0;
  for (int step = 0; step < m.config.steps; ++step) {
    const torch::Tensor idx = torch::randint(n, {m.config.batch_size}, gen, torch::kInt64);
    torch::Tensor target;
    {
      torch::NoGradGuard g;
      const torch::Tensor xn = x_next.index_select(0, idx);
      target = r.index_select(0, idx) + m.config.discount * (1 - d.index_select(0, idx)) * torch::min(m.t1->forward(xn), m.t2->forward(xn));
    }
    const torch::Tensor xb = x.index_select(0, idx);
    const torch::Tensor loss = torch::mse_loss(m.q1->forward(xb), target) + torch::mse_loss(m.q2->forward(xb), target);
    opt.zero_grad();
    loss.backward();
    opt.step();
    {
      torch::NoGradGuard g;
      auto avg = [&](torch::nn::Sequential& dst, torch::nn::Sequential& src) {
        auto a = dst->parameters(), b = src->parameters();
        for (size_t i = 0; i < a.size(); ++i) a[i].mul_(m.config.polyak).add_(b[i], 1 - m.config.polyak);
      };
      avg(m.t1, m.q1);
      avg(m.t2, m.q2);
    }
    last = loss.item<float>();
    if (progress) progress(step + 1, m.config.steps, last);  // ProgressBar throttles its drawing, as for the trainer's
  }
  return last;
}

std::vector<float> RiskCritic::q(const Mat& obs, const Mat& actions) const {
  torch::NoGradGuard g;
  const torch::Tensor x = impl_->inputs(obs, actions);
  const torch::Tensor q = torch::min(impl_->q1->forward(x), impl_->q2->forward(x)).contiguous();
  return std::vector<float>(q.data_ptr<float>(), q.data_ptr<float>() + q.numel());
}

void RiskCritic::save(const std::string& path) const {
  torch::serialize::OutputArchive archive, q1, q2;
  archive.write("format", c10::IValue(std::string("diffdagger-critic")));
  write_normalizers(archive, impl_->obs_norm, impl_->act_norm);
  impl_->q1->save(q1);
  impl_->q2->save(q2);
  archive.write("q1", q1);
  archive.write("q2", q2);
  save_archive_atomically(archive, path, "critic");
}

void RiskCritic::load(const std::string& path) {
  if (!std::filesystem::exists(path)) throw Error(path + ": no such critic file");
  torch::serialize::InputArchive archive, q1, q2;
  load_archive_checked(archive, path, "critic");
  try {
    c10::IValue format;
    if (!archive.try_read("format", format) || !format.isString() || format.toStringRef() != "diffdagger-critic")
      throw Error(path + ": not a diffdagger critic file (missing field 'format')");
    auto [obs_norm, act_norm] = read_normalizers(archive, path, impl_->obs_dim, impl_->action_dim, "this critic's observations and actions");
    archive.read("q1", q1);
    archive.read("q2", q2);
    load_modules_checked({{*impl_->q1, q1, "q1."}, {*impl_->q2, q2, "q2."}}, path);
    impl_->obs_norm = std::move(obs_norm);
    impl_->act_norm = std::move(act_norm);
  } catch (const c10::Error& e) {
    throw Error(path + ": not a readable critic of this size (truncated, corrupt or another network): " + first_line(e.what()));
  }
}

}  // namespace dd
