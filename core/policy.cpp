#include "core/policy.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>

#include "core/chunks.h"
#include "core/gate.h"
#include "core/isolate.h"
#include "core/runtime.h"
#include "core/nn/policy_impl.h"
#include "core/nn/archive_io.h"
#include "core/nn/bf16_gemm.h"
#include "core/nn/fast_unet.h"

namespace dd {
namespace {

// Rows per batched forward pass when scoring many pairs: large enough to keep oneDNN busy,
// small enough to stay in cache-friendly sizes.
constexpr int kRowsPerPass = 2048;

// Rows per denoising loop when sampling many chunks (sample_batch).
constexpr int64_t kSampleRowsPerPass = 512;

// Calls fn(start, len) over the pairs [0, n) in blocks of about `rows_per_pass` rows,
// `rows_per_pair` rows to a pair.
template <class Fn>
void for_each_block(int64_t n, int rows_per_pair, Fn&& fn, int64_t rows_per_pass = kRowsPerPass) {
  const int64_t per_pass = std::max<int64_t>(1, rows_per_pass / rows_per_pair);
  for (int64_t start = 0; start < n; start += per_pass) fn(start, std::min<int64_t>(per_pass, n - start));
}

// Scores the pairs [0, n) block by block, as for_each_block: `score(start, len, gen)` returns
// `per_pair` floats a pair, drawing its noise from `gen`; `skip(len, gen)` makes the same draws and
// nothing else. Returns the floats of every pair in order, and leaves `gen` where scoring every block
// in turn would. With split_in_two_processes(), two one-thread children score alternate blocks, each
// skipping the other's, so every block sees the noise it would see here (the numbers of a --threads
// 1 run); `progress(pairs done, last value)` reports as blocks finish.
template <class Score, class Skip>
std::vector<float> score_blocks(int64_t n, int rows_per_pair, int per_pair, torch::Generator& gen, Score&& score, Skip&& skip,
                                const std::function<void(int64_t, float)>& progress) {
  const int64_t per_pass = std::max<int64_t>(1, kRowsPerPass / rows_per_pair), blocks = (n + per_pass - 1) / per_pass;
  std::vector<float> out;
  out.reserve(static_cast<size_t>(n * per_pair));
  if (blocks < 4 || !split_in_two_processes()) {
    for_each_block(n, rows_per_pair, [&](int64_t start, int64_t len) {
      const std::vector<float> v = score(start, len, gen);
      out.insert(out.end(), v.begin(), v.end());
      if (progress) progress(start + len, out.back());
    });
    return out;
  }
  const torch::Tensor start_state = gen.get_state();
  auto job = [&](int j, const ReportFn& report) {
    torch::Generator g = make_generator(0);
    g.set_state(start_state);
    Bytes b;
    for_each_block(n, rows_per_pair, [&](int64_t start, int64_t len) {
      if ((start / per_pass) % 2 != j) {
        skip(len, g);
        return;
      }
      const std::vector<float> v = score(start, len, g);
      b.out.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(float));
      report(fmt::format("{} {}", len, v.back()));
    });
    return std::move(b.out);
  };
  int64_t done = 0;
  auto on_report = [&](int, const std::string& message) {
    long long len = 0;
    float last = 0;
    if (std::sscanf(message.c_str(), "%lld %f", &len, &last) != 2) return;
    done += len;
    if (progress) progress(std::min(done, n), last);
  };
  spdlog::debug("scoring {} training pairs in two child processes", n);
  const std::vector<std::string> parts = run_in_children(2, 2, "scoring training pairs", job, on_report);
  size_t at[2] = {0, 0};
  for_each_block(n, rows_per_pair, [&](int64_t start, int64_t len) {
    const int j = static_cast<int>((start / per_pass) % 2);
    const size_t bytes = static_cast<size_t>(len * per_pair) * sizeof(float);
    if (parts[static_cast<size_t>(j)].size() < at[j] + bytes) throw Error("scoring training pairs: a child process sent too few values");
    const auto* p = reinterpret_cast<const float*>(parts[static_cast<size_t>(j)].data() + at[j]);
    out.insert(out.end(), p, p + len * per_pair);
    at[j] += bytes;
    skip(len, gen);
  });
  return out;
}

// The expected losses of the pairs (obs, chunks), n_samples rows each, in score_blocks' blocks.
std::vector<float> pair_losses(const DiffusionPolicy::Impl& impl, const torch::Tensor& obs, const torch::Tensor& chunks,
                               int n_samples, torch::Generator& gen, const std::function<void(int64_t, float)>& progress) {
  const int64_t noise_per_pair = static_cast<int64_t>(n_samples) * chunks.size(1) * chunks.size(2);
  return score_blocks(
      obs.size(0), n_samples, 1, gen,
      [&](int64_t start, int64_t len, torch::Generator& g) {
        const torch::Tensor l = impl.expected_loss(obs.narrow(0, start, len), chunks.narrow(0, start, len), n_samples, g);
        const float* p = l.data_ptr<float>();
        return std::vector<float>(p, p + len);
      },
      [&](int64_t len, torch::Generator& g) { torch::randn({len * noise_per_pair}, g); }, progress);
}

torch::Tensor to_tensor(const Mat& m) {
  return torch::from_blob(const_cast<float*>(m.data()), {m.rows(), m.cols()}, torch::kFloat32).clone();
}

Mat to_mat(const torch::Tensor& t) {
  const torch::Tensor c = t.contiguous().to(torch::kFloat32);
  return Eigen::Map<const Mat>(c.data_ptr<float>(), c.size(0), c.numel() / std::max<int64_t>(c.size(0), 1));
}

std::string join(const std::vector<int>& v) {
  std::string s;
  for (int x : v) s += (s.empty() ? "" : ",") + std::to_string(x);
  return s;
}

}  // namespace

torch::Generator make_generator(uint64_t seed) { return at::detail::createCPUGenerator(seed); }

DiffusionPolicy::Impl::Impl(const PolicyConfig& c, uint64_t seed)
    : config(c), scheduler(c.scheduler), obs_norm(c.obs_dim), act_norm(c.action_norm_dim()) {
  torch::manual_seed(seed);  // parameter initialisation draws from the global generator
  try {
    model = nn::ConditionalUnet1D(c.action_dim, c.obs_dim, c.unet);
    ema = nn::ConditionalUnet1D(c.action_dim, c.obs_dim, c.unet);
  } catch (const c10::Error& e) {  // out of memory: a config's sizes are bounded, not its product
    const int64_t n = nn::parameter_count(c.action_dim, c.obs_dim, c.unet);
    throw Error("policy: could not build its network of " + std::to_string(n) + " parameters (unet.down_dims, " +
                "unet.kernel_size, obs_dim): " + first_line(e.what()));
  }
  for (auto& p : ema->parameters()) p.set_requires_grad(false);
  copy_model_to_ema();
}

void DiffusionPolicy::Impl::copy_model_to_ema() {
  torch::NoGradGuard no_grad;
  auto src = model->parameters();
  auto dst = ema->parameters();
  for (size_t i = 0; i < src.size(); ++i) dst[i].copy_(src[i]);
  weights_changed();
}

std::shared_ptr<const nn::FastDenoiser> DiffusionPolicy::Impl::fast_denoiser(const nn::ConditionalUnet1DImpl& net) const {
  const FastKey key{&net, net.parameters().front().data_ptr(), weights_version_.load(), precision};
  std::lock_guard<std::mutex> lock(fast_mutex_);
  // One slot per network: with score_weights raw, sampling (ema) and scoring (model) alternate.
  FastSlot& slot = fast_[&net == model.get() ? 1 : 0];
  if (!slot.denoiser || !(slot.key == key)) {
    slot.denoiser = std::make_shared<const nn::FastDenoiser>(net, fast_precision());
    slot.key = key;
  }
  return slot.denoiser;
}

torch::Tensor DiffusionPolicy::Impl::obs_tensor(const Mat& obs) const {
  if (obs.cols() != config.obs_dim)
    throw Error("policy: observation has " + std::to_string(obs.cols()) + " features, config.obs_dim is " +
                std::to_string(config.obs_dim));
  return to_tensor(obs_norm.normalize(obs));
}

Mat DiffusionPolicy::Impl::relative_chunks(const Mat& obs, const Mat& chunk_rows) const {
  if (config.relative_actions.empty()) return chunk_rows;
  if (obs.rows() != chunk_rows.rows() || obs.cols() != config.obs_dim)
    throw Error("policy: " + std::to_string(chunk_rows.rows()) + " chunks but " + std::to_string(obs.rows()) + " observations of " +
                std::to_string(obs.cols()) + " features (obs_dim " + std::to_string(config.obs_dim) + ")");
  Mat out = chunk_rows;
  const int A = config.action_dim;
  for (Eigen::Index b = 0; b < out.rows(); ++b)
    for (int k = 0; k < config.horizon; ++k)
      for (const auto& [a, o] : config.relative_actions) out(b, k * A + a) -= obs(b, o);
  return out;
}

Mat DiffusionPolicy::Impl::raw_chunk(const torch::Tensor& chunk, const Eigen::Ref<const Vec>& obs) const {
  Mat m = config.action_norm_per_step
              ? Mat(Eigen::Map<const Mat>(act_norm.unnormalize(to_mat(chunk.reshape({1, -1}))).data(), config.horizon, config.action_dim))
              : act_norm.unnormalize(to_mat(chunk.reshape({config.horizon, config.action_dim})));
  for (const auto& [a, o] : config.relative_actions) m.col(a).array() += obs[o];
  return m;
}

torch::Tensor DiffusionPolicy::Impl::chunk_tensor(const Mat& obs, const Mat& raw_rows) const {
  const int A = config.action_dim, T = config.horizon;
  if (raw_rows.cols() != T * A)
    throw Error("policy: action chunk has " + std::to_string(raw_rows.cols()) + " values, expected horizon*action_dim = " +
                std::to_string(T * A));
  const Mat chunk_rows = relative_chunks(obs, raw_rows);
  if (config.action_norm_per_step) return to_tensor(act_norm.normalize(chunk_rows)).view({chunk_rows.rows(), T, A});
  const Mat steps = Eigen::Map<const Mat>(chunk_rows.data(), chunk_rows.rows() * T, A);
  return to_tensor(act_norm.normalize(steps)).view({chunk_rows.rows(), T, A});
}

torch::Tensor DiffusionPolicy::Impl::expected_loss(const torch::Tensor& obs, const torch::Tensor& chunks,
                                                   int n_samples, torch::Generator& gen) const {
  return row_losses(obs, chunks, n_samples, gen).mean(1);
}

torch::Tensor DiffusionPolicy::Impl::row_losses(const torch::Tensor& obs, const torch::Tensor& chunks, int n_samples,
                                                torch::Generator& gen) const {
  return row_losses(obs, chunks, n_samples, gen, {score_space}, scored_timesteps())[0];
}

std::vector<torch::Tensor> DiffusionPolicy::Impl::row_losses(const torch::Tensor& obs, const torch::Tensor& chunks, int n_samples,
                                                             torch::Generator& gen, const std::vector<ScoreSpace>& spaces,
                                                             int timesteps) const {
  torch::NoGradGuard no_grad;
  const int64_t B = obs.size(0), n = n_samples, T = timesteps;
  // Condition each (pair, timestep) once: B * T rows instead of B * n.
  const torch::Tensor t_distinct = torch::arange(T, torch::kInt64).repeat({B});
  const torch::Tensor obs_distinct = obs.repeat_interleave(T, 0);
  nn::ConditionalUnet1D net = scorer();
  const std::vector<torch::Tensor> films = net->film(net->condition(t_distinct, obs_distinct));
  // Row (p, i) has timestep i mod T and uses conditioning row p * T + (i mod T).
  const torch::Tensor t_rows = (torch::arange(n, torch::kInt64) % T).repeat({B});
  const torch::Tensor cond_rows = torch::arange(B, torch::kInt64).repeat_interleave(n) * T + t_rows;
  std::vector<torch::Tensor> row_films;
  row_films.reserve(films.size());
  for (const auto& f : films) row_films.push_back(f.index_select(0, cond_rows));

  const torch::Tensor x0 = chunks.repeat_interleave(n, 0);
  const torch::Tensor eps = torch::randn(x0.sizes(), gen, x0.options());
  const torch::Tensor x_t = scheduler.add_noise(x0, eps, t_rows);
  // float32: torch's pass (at N_b rows both paths are sgemm-bound and equally fast, bench_policy);
  // bfloat16: FastDenoiser's
  const torch::Tensor pred = precision == InferencePrecision::kFloat32 ? net->denoise(x_t, row_films)
                                                                       : fast_denoiser(*net)->denoise(x_t, row_films);
  std::vector<torch::Tensor> out;
  for (const ScoreSpace space : spaces) {
    torch::Tensor err;
    switch (space) {
      case ScoreSpace::kTarget: err = pred - scheduler.target(x0, eps, t_rows); break;
      case ScoreSpace::kEpsilon: err = scheduler.predicted_eps(pred, x_t, t_rows) - eps; break;
      case ScoreSpace::kSample: err = scheduler.predicted_x0(pred, x_t, t_rows) - x0; break;
      case ScoreSpace::kVelocity:
        err = scheduler.velocity(scheduler.predicted_x0(pred, x_t, t_rows), scheduler.predicted_eps(pred, x_t, t_rows), t_rows) -
              scheduler.velocity(x0, eps, t_rows);
        break;
    }
    out.push_back(err.pow(2).reshape({B, n, -1}).mean(2));
  }
  return out;
}

torch::Tensor DiffusionPolicy::Impl::sample(const torch::Tensor& obs, torch::Generator& gen) const {
  torch::NoGradGuard no_grad;
  const int64_t B = obs.size(0);
  const std::vector<int64_t> ts = scheduler.inference_timesteps();
  const auto n = static_cast<int64_t>(ts.size());
  // Condition all n * B (timestep, row) pairs at once, timestep-major, and slice per step.
  const torch::Tensor t_all = torch::tensor(ts, torch::kInt64).repeat_interleave(B);
  const std::vector<torch::Tensor> films = ema->film(ema->condition(t_all, obs.repeat({n, 1})));
  torch::Tensor x = torch::randn({B, config.horizon, config.action_dim}, gen, torch::kFloat32);
  // FastDenoiser leads where torch's per-operator cost dominates (few rows); from about 16 rows on,
  // torch's oneDNN convolutions beat its im2col products (bench_policy's SampleRows), and the
  // ensembles' thresholds sample every training observation at once.
  if (torch_denoise || (precision == InferencePrecision::kFloat32 && B >= kFastSampleMaxRows)) {
    std::vector<torch::Tensor> step_films(films.size());
    for (int64_t i = 0; i < n; ++i) {
      for (size_t k = 0; k < films.size(); ++k) step_films[k] = films[k].narrow(0, i * B, B);
      x = scheduler.step(ema->denoise(x, step_films), ts[static_cast<size_t>(i)], x, gen);
    }
    return x.clamp(-1.0, 1.0);
  }
  // The loop on raw floats: the denoising pass on FastDenoiser, the scheduler's scalar step, and the
  // same generator draws in the same order as the tensor path.
  const std::shared_ptr<const nn::FastDenoiser> fast = fast_denoiser(*ema);
  const size_t chunk = static_cast<size_t>(config.horizon) * config.action_dim;
  std::vector<torch::Tensor> fc;
  for (const auto& f : films) fc.push_back(f.contiguous());
  std::vector<nn::FastDenoiser::Film> rows(films.size());
  std::vector<float> out(static_cast<size_t>(B) * chunk);
  float* xs = x.data_ptr<float>();
  for (int64_t i = 0; i < n; ++i) {
    const int64_t t = ts[static_cast<size_t>(i)];
    for (size_t k = 0; k < fc.size(); ++k) rows[k] = {fc[k].data_ptr<float>() + i * B * fc[k].size(1), fc[k].size(1)};
    fast->denoise(xs, static_cast<int>(B), config.horizon, rows, out.data());
    const torch::Tensor noise = scheduler.step_draws_noise(t) ? torch::randn(x.sizes(), gen, x.options()) : torch::Tensor();
    scheduler.step(out.data(), t, xs, out.size(), noise.defined() ? noise.data_ptr<float>() : nullptr);
  }
  return x.clamp(-1.0, 1.0);
}

torch::Tensor DiffusionPolicy::Impl::sample_reference(const torch::Tensor& obs, torch::Generator& gen) const {
  torch::NoGradGuard no_grad;
  const int64_t B = obs.size(0);
  torch::Tensor x = torch::randn({B, config.horizon, config.action_dim}, gen, torch::kFloat32);
  for (const int64_t t : scheduler.inference_timesteps()) {
    const torch::Tensor out = ema->forward(x, torch::full({B}, t, torch::kInt64), obs);
    x = scheduler.step(out, t, x, gen);
  }
  return x.clamp(-1.0, 1.0);
}

DiffusionPolicy::DiffusionPolicy(const PolicyConfig& config, uint64_t seed, bool announce) {
  config.validate();
  impl_ = std::make_unique<Impl>(config, seed);
  if (announce)
    spdlog::info("policy: ConditionalUnet1D down_dims [{}], kernel {}, step embedding {}, T_p {}, T_d {}: {} parameters",
               join(config.unet.down_dims), config.unet.kernel_size, config.unet.step_embed_dim, config.horizon,
               config.scheduler.num_train_timesteps, num_parameters());
}

DiffusionPolicy::~DiffusionPolicy() = default;

const PolicyConfig& DiffusionPolicy::config() const { return impl_->config; }

int64_t DiffusionPolicy::num_parameters() const {
  int64_t n = 0;
  for (const auto& p : impl_->model->parameters()) n += p.numel();
  return n;
}

const Normalizer& DiffusionPolicy::obs_normalizer() const { return impl_->obs_norm; }
const Normalizer& DiffusionPolicy::action_normalizer() const { return impl_->act_norm; }

void DiffusionPolicy::set_normalizers(Normalizer obs, Normalizer action) {
  if (obs.dim() != impl_->config.obs_dim || action.dim() != impl_->config.action_norm_dim())
    throw Error("policy: normalizer sizes (" + std::to_string(obs.dim()) + ", " + std::to_string(action.dim()) +
                ") do not match obs_dim and action_dim (horizon * action_dim with action_norm_per_step)");
  impl_->obs_norm = std::move(obs);
  impl_->act_norm = std::move(action);
}

std::vector<Mat> DiffusionPolicy::sample_batch(const Mat& obs, uint64_t seed) const {
  // Blocks of kSampleRowsPerPass rows, one after another, all drawing from one generator. An
  // ensemble's threshold samples every training observation: in one batch of 16,384 rows the
  // conditioning and activations take gigabytes, and a row costs six times as much as in blocks
  // (bench_policy's SampleManyRowsOneBatch against SampleManyRows). A batch of at most one block
  // draws the very noise it drew before the blocks.
  torch::Generator gen = make_generator(seed);
  std::vector<Mat> out;
  out.reserve(static_cast<size_t>(obs.rows()));
  for_each_block(
      obs.rows(), 1,
      [&](int64_t start, int64_t len) {
        const torch::Tensor x = impl_->sample(impl_->obs_tensor(obs.middleRows(start, len)), gen);
        for (int64_t b = 0; b < x.size(0); ++b) out.push_back(impl_->raw_chunk(x[b], obs.row(start + b).transpose()));
      },
      kSampleRowsPerPass);
  return out;
}

Mat DiffusionPolicy::sample(const Vec& obs, uint64_t seed) const {
  return sample_batch(obs.transpose(), seed).front();
}

void DiffusionPolicy::reinitialize(uint64_t seed) {
  auto fresh = std::make_unique<Impl>(impl_->config, seed);
  fresh->obs_norm = impl_->obs_norm;
  fresh->act_norm = impl_->act_norm;
  fresh->score_weights = impl_->score_weights;
  fresh->score_space = impl_->score_space;
  fresh->score_timesteps = impl_->score_timesteps;
  fresh->precision = impl_->precision;
  fresh->torch_denoise = impl_->torch_denoise;
  impl_ = std::move(fresh);
}

void DiffusionPolicy::set_score_weights(ScoreWeights w) { impl_->score_weights = w; }

InferencePrecision inference_precision_from(const std::string& name) {
  if (name == "float32") return InferencePrecision::kFloat32;
  if (name == "bfloat16") return InferencePrecision::kBFloat16;
  throw Error("inference precision: '" + name + "' is not float32 or bfloat16");
}

std::string to_string(InferencePrecision p) { return p == InferencePrecision::kBFloat16 ? "bfloat16" : "float32"; }

void DiffusionPolicy::set_inference_precision(InferencePrecision p) {
  if (p == InferencePrecision::kBFloat16 && !nn::have_bf16_gemm())
    throw Error("inference precision bfloat16 (method.precision): oneDNN's bf16 matmul is not available here (a build without libdnnl-dev, or a CPU without AVX-512); use float32");
  impl_->precision = p;
}

InferencePrecision DiffusionPolicy::inference_precision() const { return impl_->precision; }
ScoreWeights DiffusionPolicy::score_weights() const { return impl_->score_weights; }
void DiffusionPolicy::set_score_space(ScoreSpace s) { impl_->score_space = s; }
ScoreSpace DiffusionPolicy::score_space() const { return impl_->score_space; }

void DiffusionPolicy::set_score_timesteps(int k) {
  const int T = impl_->config.scheduler.num_train_timesteps;
  if (k < 0 || k > T)
    throw Error("score timesteps: " + std::to_string(k) + " is not between 0 (every timestep) and T_d = " + std::to_string(T));
  impl_->score_timesteps = k == T ? 0 : k;
}
int DiffusionPolicy::score_timesteps() const { return impl_->scored_timesteps(); }

ScoreSpace score_space_from(const std::string& name) {
  if (name == "target") return ScoreSpace::kTarget;
  if (name == "epsilon") return ScoreSpace::kEpsilon;
  if (name == "sample") return ScoreSpace::kSample;
  if (name == "v" || name == "v_prediction") return ScoreSpace::kVelocity;
  throw Error("score space '" + name + "' is not one of target, epsilon, sample, v");
}

std::string to_string(ScoreSpace s) {
  switch (s) {
    case ScoreSpace::kTarget: return "target";
    case ScoreSpace::kEpsilon: return "epsilon";
    case ScoreSpace::kSample: return "sample";
    case ScoreSpace::kVelocity: return "v";
  }
  return "?";
}

std::vector<float> DiffusionPolicy::loss_by_timestep(const Vec& obs, const Mat& chunk, uint64_t seed, int n_samples) const {
  return loss_by_timestep(obs, chunk, seed, n_samples, {impl_->score_space})[0];
}

std::vector<std::vector<float>> DiffusionPolicy::loss_by_timestep(const Vec& obs, const Mat& chunk, uint64_t seed, int n_samples,
                                                                  const std::vector<ScoreSpace>& spaces) const {
  const int T = config().scheduler.num_train_timesteps;
  if (n_samples < T || n_samples % T != 0)
    throw Error("policy: loss_by_timestep needs a multiple of T_d = " + std::to_string(T) + " rows, got " + std::to_string(n_samples));
  torch::Generator gen = make_generator(seed);
  const Mat row = Eigen::Map<const Mat>(chunk.data(), 1, chunk.size());
  // row i has timestep i mod T_d: the rows of timestep t are every T_d-th
  std::vector<std::vector<float>> out;
  for (const torch::Tensor& rows :
       impl_->row_losses(impl_->obs_tensor(obs.transpose()), impl_->chunk_tensor(obs.transpose(), row), n_samples, gen, spaces, config().scheduler.num_train_timesteps)) {
    const torch::Tensor l = rows.reshape({n_samples / T, T}).mean(0).contiguous();
    out.emplace_back(l.data_ptr<float>(), l.data_ptr<float>() + T);
  }
  return out;
}

float DiffusionPolicy::expected_loss(const Vec& obs, const Mat& chunk, uint64_t seed, int n_samples) const {
  torch::Generator gen = make_generator(seed);
  const Mat row = Eigen::Map<const Mat>(chunk.data(), 1, chunk.size());
  return impl_->expected_loss(impl_->obs_tensor(obs.transpose()), impl_->chunk_tensor(obs.transpose(), row), n_samples, gen)
      .item<float>();
}

std::vector<float> DiffusionPolicy::expected_losses(const ChunkDataset& data, uint64_t seed, int n_samples,
                                                    const ProgressFn& progress) const {
  torch::Generator gen = make_generator(seed);
  const torch::Tensor obs = impl_->obs_tensor(data.obs);
  const torch::Tensor chunks = impl_->chunk_tensor(data.obs, data.chunks);
  return pair_losses(*impl_, obs, chunks, n_samples, gen, [&](int64_t done, float last) {
    if (progress) progress(static_cast<int>(done), data.size(), last);
  });
}

// Rows per pair of a screening pass (loss_quantile, decide_screened): an eighth of n_samples, whole
// strata of T timesteps, at least two rows per timestep (for the within-stratum variance); 0 where
// that is more than a quarter of n_samples (screening would not pay).
static int screening_rows(int n_samples, int T) {
  const int m = std::max((n_samples / 8 + T - 1) / T, 2) * T;
  return 4 * m > n_samples ? 0 : m;
}

// The standard error of a screening mean over rows (..., k, T): k rows at each of T timesteps, so the
// stratified estimate var(mean) = sum_t var_t / k / T^2. Shape (...).
static torch::Tensor stratified_se(const torch::Tensor& rows) {
  const int64_t k = rows.size(-2), T = rows.size(-1);
  return (rows.var(-2, /*unbiased=*/true).sum(-1) / static_cast<double>(k * T * T)).sqrt();
}

LossQuantile DiffusionPolicy::loss_quantile(const ChunkDataset& data, double alpha, uint64_t seed, int n_samples,
                                            bool screen, const ProgressFn& progress) const {
  if (data.size() == 0) throw Error("policy: no training pairs to set a threshold over");
  const int T = impl_->scored_timesteps();
  const int m = screening_rows(n_samples, T);
  LossQuantile q;
  q.pairs = data.size();
  if (!screen || m == 0) {
    q.threshold = quantile(expected_losses(data, seed, n_samples, progress), alpha);
    q.refined = q.pairs;
    return q;
  }
  q.screen_samples = m;
  torch::Generator gen = make_generator(seed);
  const torch::Tensor obs = impl_->obs_tensor(data.obs);
  const torch::Tensor chunks = impl_->chunk_tensor(data.obs, data.chunks);
  const auto n = static_cast<size_t>(data.size());
  const int64_t k = m / T;  // rows per timestep
  std::vector<float> screened(n), bound(n);  // screening mean, and mean + z standard errors
  const int64_t noise_per_pair = static_cast<int64_t>(m) * chunks.size(1) * chunks.size(2);
  const std::vector<float> screening = score_blocks(
      data.size(), m, 2, gen,
      [&](int64_t start, int64_t len, torch::Generator& g) {
        // (len, m) -> (len, k, T): row j * T + t has timestep t
        const torch::Tensor rows = impl_->row_losses(obs.narrow(0, start, len), chunks.narrow(0, start, len), m, g).view({len, k, T});
        const torch::Tensor mean = rows.mean({1, 2});
        const torch::Tensor hi = mean + LossQuantile::kScreenZ * stratified_se(rows);
        const torch::Tensor both = torch::stack({hi, mean}, 1).contiguous();  // (bound, mean) a pair
        const float* p = both.data_ptr<float>();
        return std::vector<float>(p, p + 2 * len);
      },
      [&](int64_t len, torch::Generator& g) { torch::randn({len * noise_per_pair}, g); },
      [&](int64_t done, float last_mean) {
        if (progress) progress(static_cast<int>(done), 2 * data.size(), last_mean);
      });
  for (size_t i = 0; i < n; ++i) {
    bound[i] = screening[2 * i];
    screened[i] = screening[2 * i + 1];
  }
  // Refine every pair that could lie above the threshold with the full n_samples rows; repeat while
  // the threshold moves below a pair's screening bound. The threshold is then always a refined
  // value, and every pair left unrefined lies below it (by kScreenZ standard errors), so the order
  // statistic is the one all pairs at n_samples rows would give.
  std::vector<float> value = screened;
  std::vector<char> refined(n, 0);
  q.threshold = quantile(value, alpha);
  for (;;) {
    std::vector<int64_t> todo;
    for (size_t i = 0; i < n; ++i)
      if (!refined[i] && bound[i] >= q.threshold) todo.push_back(static_cast<int64_t>(i));
    if (todo.empty()) break;
    const torch::Tensor idx = torch::tensor(todo, torch::kInt64);
    const torch::Tensor o = obs.index_select(0, idx), c = chunks.index_select(0, idx);
    const int refined_before = q.refined;
    const std::vector<float> l = pair_losses(*impl_, o, c, n_samples, gen, [&](int64_t done, float last) {
      if (progress) progress(std::min(2 * data.size() - 1, data.size() + refined_before + static_cast<int>(done)), 2 * data.size(), last);
    });
    for (size_t j = 0; j < todo.size(); ++j) {
      value[static_cast<size_t>(todo[j])] = l[j];
      refined[static_cast<size_t>(todo[j])] = 1;
    }
    q.refined += static_cast<int>(todo.size());
    q.threshold = quantile(value, alpha);
  }
  if (progress) progress(2 * data.size(), 2 * data.size(), q.threshold);
  return q;
}

Decision DiffusionPolicy::decide(const Vec& obs, uint64_t seed, int n_samples) const { return decide(obs, seed, n_samples, {}); }

Decision DiffusionPolicy::decide_screened(const Vec& obs, uint64_t seed, int n_samples, float threshold) const {
  const int T = impl_->scored_timesteps();
  const int m = screening_rows(n_samples, T);
  if (m == 0 || n_samples % T != 0 || !std::isfinite(threshold)) return decide(obs, seed, n_samples);
  torch::Generator gen = make_generator(seed);
  const torch::Tensor o = impl_->obs_tensor(obs.transpose());
  const torch::Tensor x = impl_->sample(o, gen);
  Decision d;
  d.chunk = impl_->raw_chunk(x[0], obs);
  // rows (k, T): row j * T + t of a block has timestep t, so every block is whole strata
  std::vector<torch::Tensor> blocks;
  for (int next = m;;) {
    blocks.push_back(impl_->row_losses(o, x, next, gen).view({next / T, T}));
    d.rows += next;
    const torch::Tensor rows = blocks.size() == 1 ? blocks[0] : torch::cat(blocks, 0);
    d.loss = rows.mean().item<float>();
    if (d.rows >= n_samples) break;
    if (d.loss + LossQuantile::kScreenZ * stratified_se(rows).item<float>() < threshold) break;
    next = std::min(d.rows, n_samples - d.rows);
  }
  return d;
}

Decision DiffusionPolicy::decide(const Vec& obs, uint64_t seed, int n_samples, const std::vector<ScoreSpace>& also) const {
  torch::Generator gen = make_generator(seed);
  const torch::Tensor o = impl_->obs_tensor(obs.transpose());
  const torch::Tensor x = impl_->sample(o, gen);
  std::vector<ScoreSpace> spaces{impl_->score_space};
  spaces.insert(spaces.end(), also.begin(), also.end());
  const std::vector<torch::Tensor> rows = impl_->row_losses(o, x, n_samples, gen, spaces, impl_->scored_timesteps());
  Decision d;
  d.loss = rows[0].mean(1).item<float>();  // what impl_->expected_loss gives: the same rows, the same mean
  d.rows = n_samples;
  for (size_t i = 1; i < rows.size(); ++i) d.also.push_back(rows[i].mean(1).item<float>());
  d.chunk = impl_->raw_chunk(x[0], obs);
  return d;
}

}  // namespace dd
