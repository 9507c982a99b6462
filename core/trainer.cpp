#include "core/trainer.h"

#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>

#include <ATen/Parallel.h>
#include <spdlog/spdlog.h>

#include "core/chunks.h"
#include "core/isolate.h"
#include "core/nn/archive_io.h"
#include "core/nn/policy_impl.h"
#include "core/runtime.h"

namespace dd {

double TrainStats::first_mean(int window) const {
  const size_t n = std::min(losses.size(), static_cast<size_t>(window));
  double s = 0;
  for (size_t i = 0; i < n; ++i) s += losses[i];
  return n ? s / n : NAN;
}

double TrainStats::last_mean(int window) const {
  const size_t n = std::min(losses.size(), static_cast<size_t>(window));
  double s = 0;
  for (size_t i = losses.size() - n; i < losses.size(); ++i) s += losses[i];
  return n ? s / n : NAN;
}

double scheduled_lr(const TrainConfig& c, int step, int total) {
  if (step < c.warmup_steps) return c.lr * (step + 1) / c.warmup_steps;
  const double span = std::max(1, total - c.warmup_steps);
  const double progress = std::min(1.0, (step - c.warmup_steps) / span);
  return c.lr * 0.5 * (1.0 + std::cos(M_PI * progress));
}

namespace {
std::atomic<bool> fused_optimizer{true};

// AdamW (torch's formulas: decoupled weight decay, then the moments, bias-corrected) on flat buffers,
// with the gradient scaled by `clip` on the way.
void adamw(float* p, const float* g, float* m, float* v, int64_t n, float clip, double lr, const TrainConfig& c, int step) {
  const float decay = static_cast<float>(1 - lr * c.weight_decay), b1 = static_cast<float>(c.beta1), b2 = static_cast<float>(c.beta2);
  const float bc1 = static_cast<float>(1 - std::pow(c.beta1, step)), bc2_sqrt = static_cast<float>(std::sqrt(1 - std::pow(c.beta2, step)));
  const float step_size = static_cast<float>(lr) / bc1, eps = 1e-8f;
  at::parallel_for(0, n, 1 << 15, [&](int64_t begin, int64_t end) {
    for (int64_t i = begin; i < end; ++i) {
      const float gi = g[i] * clip;
      m[i] = m[i] * b1 + gi * (1 - b1);
      v[i] = v[i] * b2 + gi * gi * (1 - b2);
      p[i] = p[i] * decay - step_size * m[i] / (std::sqrt(v[i]) / bc2_sqrt + eps);
    }
  });
}
}  // namespace

void set_fused_optimizer(bool on) { fused_optimizer = on; }
bool fused_optimizer_on() { return fused_optimizer; }

namespace {
// OpenMP's pool size is per thread: this one's, for a scope.
class OneThread {
 public:
  OneThread() : before_(at::get_num_threads()) { set_openmp_threads(1); }
  ~OneThread() { set_openmp_threads(before_); }
  OneThread(const OneThread&) = delete;
  OneThread& operator=(const OneThread&) = delete;

 private:
  int before_;
};

// Offsets into the memory shared with the data-parallel child, each 64-byte aligned.
struct SharedLayout {
  size_t params, grad, loss, t, x, target, obs, bytes;
  SharedLayout(int64_t n, int64_t rows, int64_t chunk, int64_t obs_dim) {
    size_t at = 0;
    auto take = [&](size_t b) {
      const size_t o = at;
      at += (b + 63) / 64 * 64;
      return o;
    };
    params = take(n * sizeof(float));
    grad = take(n * sizeof(float));
    loss = take(sizeof(double));
    t = take(rows * sizeof(int64_t));
    x = take(rows * chunk * sizeof(float));
    target = take(rows * chunk * sizeof(float));
    obs = take(rows * obs_dim * sizeof(float));
    bytes = at;
  }
};
}  // namespace

struct Trainer::State {
  State(DiffusionPolicy& p, const TrainConfig& c)
      : impl(p.impl()),
        config(c),
        gen(make_generator(c.seed)),
        params(impl.model->parameters()),
        opt(params, torch::optim::AdamWOptions(c.lr).betas({c.beta1, c.beta2}).weight_decay(c.weight_decay)) {}

  DiffusionPolicy::Impl& impl;
  TrainConfig config;
  torch::Generator gen;
  std::vector<torch::Tensor> params, ema_params;
  torch::optim::AdamW opt;  // the reference path's optimiser (idle when fused)
  bool fused = fused_optimizer;
  // fused: every parameter, its gradient and its EMA weight is a view into these
  torch::Tensor flat, flat_grad, flat_ema, exp_avg, exp_avg_sq;
  torch::Tensor obs, chunks;  // normalised training pairs
  int step = 0;
  // Data-parallel training (two threads or more, fused optimiser): a forked child computes the
  // gradient of the minibatch's second half while this process computes the first's, one thread each.
  std::unique_ptr<ChildWorker> worker;
  std::unique_ptr<SharedLayout> layout;
  int64_t half = 0;  // rows this process takes; the child takes batch_size - half

  // The summed squared error of rows [begin, begin + rows) over the whole minibatch's element count,
  // backpropagated into flat_grad (added to what is there): the two halves' losses and gradients add
  // up to the minibatch's mean-squared-error loss and its gradient.
  float half_loss(const torch::Tensor& x, const torch::Tensor& t, const torch::Tensor& o, const torch::Tensor& target,
                  int64_t elements) {
    const torch::Tensor pred = impl.model->forward(x, t, o);
    const torch::Tensor loss = (pred - target).pow(2).sum() / static_cast<double>(elements);
    loss.backward();
    return loss.item<float>();
  }

  // In the child: its half of the step whose inputs and weights the parent put in `shared`.
  void child_half(char* shared) {
    const SharedLayout& L = *layout;
    const int64_t rows = config.batch_size - half, n = flat.numel();
    const int64_t T = impl.config.horizon, A = impl.config.action_dim, O = impl.config.obs_dim;
    torch::NoGradGuard no_grad_for_copies;
    flat.copy_(torch::from_blob(shared + L.params, {n}));
    flat_grad.zero_();
    const auto f32 = torch::TensorOptions().dtype(torch::kFloat32);
    const torch::Tensor x = torch::from_blob(shared + L.x, {rows, T, A}, f32);
    const torch::Tensor t = torch::from_blob(shared + L.t, {rows}, torch::TensorOptions().dtype(torch::kInt64));
    const torch::Tensor o = torch::from_blob(shared + L.obs, {rows, O}, f32);
    const torch::Tensor target = torch::from_blob(shared + L.target, {rows, T, A}, f32);
    float loss;
    {
      torch::AutoGradMode grad(true);
      loss = half_loss(x, t, o, target, config.batch_size * T * A);
    }
    std::memcpy(shared + L.grad, flat_grad.data_ptr<float>(), n * sizeof(float));
    *reinterpret_cast<double*>(shared + L.loss) = loss;
  }

  void start_worker() {
    const int64_t T = impl.config.horizon, A = impl.config.action_dim, O = impl.config.obs_dim;
    half = config.batch_size / 2;
    layout = std::make_unique<SharedLayout>(flat.numel(), config.batch_size - half, T * A, O);
    worker = std::make_unique<ChildWorker>("data-parallel training", layout->bytes, [this](char* shared) { child_half(shared); });
  }

  // Moves the parameters, their gradients and the EMA weights into flat buffers (views keep the
  // modules' tensors valid) and starts the moments at zero.
  void flatten() {
    torch::NoGradGuard no_grad;
    int64_t n = 0;
    for (const auto& p : params) n += p.numel();
    flat = torch::empty({n});
    flat_grad = torch::zeros({n});
    flat_ema = torch::empty({n});
    exp_avg = torch::zeros({n});
    exp_avg_sq = torch::zeros({n});
    int64_t off = 0;
    for (size_t i = 0; i < params.size(); ++i) {
      const int64_t k = params[i].numel();
      flat.narrow(0, off, k).copy_(params[i].reshape(-1));
      flat_ema.narrow(0, off, k).copy_(ema_params[i].reshape(-1));
      params[i].set_data(flat.narrow(0, off, k).view(params[i].sizes()));
      params[i].mutable_grad() = flat_grad.narrow(0, off, k).view(params[i].sizes());
      ema_params[i].set_data(flat_ema.narrow(0, off, k).view(ema_params[i].sizes()));
      off += k;
    }
  }
};

Trainer::Trainer(DiffusionPolicy& policy, const ChunkDataset& data, const TrainConfig& config) {
  config.validate();
  const PolicyConfig& pc = policy.config();
  if (data.size() == 0) throw Error("train: the data set is empty");
  if (data.obs_dim() != pc.obs_dim || data.action_dim != pc.action_dim || data.horizon != pc.horizon)
    throw Error("train: data set shapes (obs " + std::to_string(data.obs_dim()) + ", action " +
                std::to_string(data.action_dim) + ", horizon " + std::to_string(data.horizon) +
                ") do not match the policy config");
  if (config.fit_normalizer) {
    // the actions as the model sees them (relative to their observations where the config says so)
    const Mat chunks = policy.impl().relative_chunks(data.obs, data.chunks);
    const Mat actions = policy.config().action_norm_per_step
                            ? chunks
                            : Mat(Eigen::Map<const Mat>(chunks.data(), chunks.rows() * data.horizon, data.action_dim));
    policy.set_normalizers(Normalizer::fit(data.obs), Normalizer::fit(actions, Normalizer::Constants::kPin));
  }
  TrainConfig resolved = config;
  resolved.steps = config.steps_for(data.size());  // the learning-rate schedule spans the steps actually run
  resolved.epochs = 0;
  state_ = std::make_unique<State>(policy, resolved);
  auto& impl = state_->impl;
  state_->obs = impl.obs_tensor(data.obs);
  state_->chunks = impl.chunk_tensor(data.obs, data.chunks);
  impl.model->train();
  impl.copy_model_to_ema();
  state_->ema_params = impl.ema->parameters();
  if (state_->fused) state_->flatten();
  // Two processes of one thread each get through a step faster than one process of two threads
  // (a step's operators use a second thread poorly). Not inside a parallel region (ensemble members
  // training side by side) and not for minibatches too small to split.
  if (state_->fused && split_in_two_processes() && resolved.batch_size >= 16) {
    try {
      state_->start_worker();
      spdlog::debug("training: each step's minibatch split with child process {}", state_->worker->pid());
    } catch (const Error& e) {
      spdlog::warn("{}; training in this process alone", e.what());
      state_->worker.reset();
    }
  }
}

Trainer::~Trainer() {
  if (state_) state_->impl.model->eval();
}

int Trainer::steps_done() const { return state_->step; }
int Trainer::worker_pid() const { return state_->worker ? state_->worker->pid() : -1; }

float Trainer::step() {
  State& s = *state_;
  auto& impl = s.impl;
  const TrainConfig& c = s.config;
  const int64_t T = impl.config.scheduler.num_train_timesteps;
  const torch::Tensor idx = torch::randint(s.obs.size(0), {c.batch_size}, s.gen, torch::kInt64);
  const torch::Tensor o = s.obs.index_select(0, idx);
  const torch::Tensor x0 = s.chunks.index_select(0, idx);
  const torch::Tensor eps = torch::randn(x0.sizes(), s.gen, x0.options());
  const torch::Tensor t = torch::randint(T, {c.batch_size}, s.gen, torch::kInt64);
  // EMA with warm-up: decay = 1 - (1 + step)^-power, capped; the first update copies.
  const double decay = std::min(c.ema_max_decay, 1.0 - std::pow(1.0 + s.step, -c.ema_power));
  float l = 0;
  const bool split = s.worker != nullptr;
  if (split) {
    const torch::Tensor x = impl.scheduler.add_noise(x0, eps, t), target = impl.scheduler.target(x0, eps, t);
    const int64_t h = s.half, rows = c.batch_size - h, elements = x.numel();
    const SharedLayout& L = *s.layout;
    char* shared = s.worker->shared();
    auto put = [&](size_t offset, const torch::Tensor& v) {
      const torch::Tensor part = v.narrow(0, h, rows).contiguous();
      std::memcpy(shared + offset, part.data_ptr(), part.nbytes());
    };
    put(L.x, x);
    put(L.t, t);
    put(L.obs, o);
    put(L.target, target);
    std::memcpy(shared + L.params, s.flat.data_ptr<float>(), s.flat.nbytes());
    // The child may be found gone when it is asked (it died between steps) or when it is waited for:
    // either way this step's second half is done here, and every later step in this process alone.
    auto without_child = [&](const Error& e) {
      spdlog::warn("{}; training goes on in this process alone", e.what());
      s.worker.reset();
    };
    bool asked = true;
    try {
      s.worker->start();
    } catch (const Error& e) {
      without_child(e);
      asked = false;
    }
    s.flat_grad.zero_();
    {
      OneThread one;  // the child works on the other core
      l = s.half_loss(x.narrow(0, 0, h), t.narrow(0, 0, h), o.narrow(0, 0, h), target.narrow(0, 0, h), elements);
    }
    bool answered = false;
    if (asked) {
      try {
        s.worker->wait();
        torch::NoGradGuard no_grad;
        s.flat_grad.add_(torch::from_blob(shared + L.grad, {s.flat_grad.numel()}));
        l += static_cast<float>(*reinterpret_cast<const double*>(shared + L.loss));
        answered = true;
      } catch (const Error& e) {
        without_child(e);
      }
    }
    if (!answered) l += s.half_loss(x.narrow(0, h, rows), t.narrow(0, h, rows), o.narrow(0, h, rows), target.narrow(0, h, rows), elements);
  }
  const torch::Tensor loss = split ? torch::Tensor() : torch::mse_loss(impl.model->forward(impl.scheduler.add_noise(x0, eps, t), t, o),
                                                                          impl.scheduler.target(x0, eps, t));
  if (s.fused) {
    if (!split) {
      s.flat_grad.zero_();
      loss.backward();
    }
    float clip = 1;
    if (c.grad_clip > 0) {
      const double norm = s.flat_grad.norm().item<double>(), coef = c.grad_clip / (norm + 1e-6);
      if (coef < 1) clip = static_cast<float>(coef);
    }
    adamw(s.flat.data_ptr<float>(), s.flat_grad.data_ptr<float>(), s.exp_avg.data_ptr<float>(), s.exp_avg_sq.data_ptr<float>(),
          s.flat.numel(), clip, scheduled_lr(c, s.step, c.steps), c, s.step + 1);
    torch::NoGradGuard no_grad;
    s.flat_ema.mul_(decay).add_(s.flat, 1.0 - decay);
  } else {
    s.opt.zero_grad();
    loss.backward();
    if (c.grad_clip > 0) torch::nn::utils::clip_grad_norm_(s.params, c.grad_clip);
    for (auto& group : s.opt.param_groups()) group.options().set_lr(scheduled_lr(c, s.step, c.steps));
    s.opt.step();
    torch::NoGradGuard no_grad;
    torch::_foreach_mul_(s.ema_params, decay);
    torch::_foreach_add_(s.ema_params, s.params, 1.0 - decay);
  }
  if (loss.defined()) l = loss.item<float>();
  if (!std::isfinite(l)) throw Error("train: the loss became non-finite at step " + std::to_string(s.step));
  impl.weights_changed();
  ++s.step;
  return l;
}

namespace {
constexpr const char* kStateFormat = "diffdagger-trainer";
constexpr int64_t kStateVersion = 1;
}  // namespace

void Trainer::save_state(const std::string& path) const {
  const State& s = *state_;
  torch::serialize::OutputArchive archive, optimizer;
  archive.write("format", c10::IValue(std::string(kStateFormat)));
  archive.write("version", c10::IValue(kStateVersion));
  archive.write("step", c10::IValue(static_cast<int64_t>(s.step)));
  archive.write("total_steps", c10::IValue(static_cast<int64_t>(s.config.steps)));
  archive.write("generator", s.gen.get_state());
  for (size_t i = 0; i < s.ema_params.size(); ++i) archive.write("ema_" + std::to_string(i), s.ema_params[i]);
  if (s.fused) {
    archive.write("exp_avg", s.exp_avg);
    archive.write("exp_avg_sq", s.exp_avg_sq);
  } else {
    s.opt.save(optimizer);
    archive.write("optimizer", optimizer);
  }
  save_archive_atomically(archive, path, "the trainer state");
}

void Trainer::resume(const std::string& path) {
  State& s = *state_;
  if (!std::filesystem::exists(path)) throw Error(path + ": no trainer state to resume from");
  torch::serialize::InputArchive archive, optimizer;
  c10::IValue format, version, step, total;
  load_archive_checked(archive, path, "trainer state");
  try {
    if (!archive.try_read("format", format) || !format.isString() || format.toStringRef() != kStateFormat)
      throw Error(path + ": not a diffdagger trainer state (field 'format')");
    if (!archive.try_read("version", version) || !version.isInt() || version.toInt() != kStateVersion)
      throw Error(path + ": trainer state version is not " + std::to_string(kStateVersion) + " (field 'version')");
    archive.read("step", step);
    archive.read("total_steps", total);
    if (total.toInt() != s.config.steps)
      throw Error(path + ": the run it continues has " + std::to_string(total.toInt()) + " steps, this one " +
                  std::to_string(s.config.steps) + " (field 'total_steps')");
    torch::Tensor gen_state;
    archive.read("generator", gen_state);
    torch::NoGradGuard no_grad;
    for (size_t i = 0; i < s.ema_params.size(); ++i) {
      torch::Tensor t;
      const std::string key = "ema_" + std::to_string(i);
      archive.read(key, t);
      check_tensor(t, path, key);
      if (!t.sizes().equals(s.ema_params[i].sizes())) throw Error(path + ": field '" + key + "' has another shape than the policy's");
      s.ema_params[i].copy_(t);
    }
    s.impl.weights_changed();
    if (s.fused) {
      torch::Tensor m, v;
      if (!archive.try_read("exp_avg", m) || !archive.try_read("exp_avg_sq", v) || m.numel() != s.exp_avg.numel() ||
          v.numel() != s.exp_avg_sq.numel())
        throw Error(path + ": no AdamW moments of this policy's size (fields 'exp_avg', 'exp_avg_sq')");
      s.exp_avg.copy_(m);
      s.exp_avg_sq.copy_(v);
    } else {
      archive.read("optimizer", optimizer);
      s.opt.load(optimizer);
    }
    s.gen.set_state(gen_state);
  } catch (const c10::Error& e) {
    throw Error(path + ": truncated or corrupt trainer state: " + first_line(e.what()));
  }
  s.step = static_cast<int>(step.toInt());
}

TrainStats train(DiffusionPolicy& policy, const ChunkDataset& data, const TrainConfig& config,
                 const ProgressFn& progress) {
  Trainer trainer(policy, data, config);
  const int steps = config.steps_for(data.size());
  TrainStats stats;
  stats.losses.reserve(static_cast<size_t>(steps));
  const auto start = std::chrono::steady_clock::now();
  for (int i = 0; i < steps; ++i) {
    stats.losses.push_back(trainer.step());
    if (progress) progress(i + 1, steps, stats.last_mean(20));
  }
  stats.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return stats;
}

}  // namespace dd
