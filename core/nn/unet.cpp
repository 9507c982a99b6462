#include "core/nn/unet.h"

#include "core/nn/mish.h"

#include <cmath>

namespace dd::nn {

torch::Tensor sinusoidal_embedding(const torch::Tensor& t, int dim) {
  const int half = dim / 2;
  const double scale = std::log(10000.0) / std::max(half - 1, 1);
  const torch::Tensor freqs = torch::exp(torch::arange(half, torch::kFloat32) * -scale);
  const torch::Tensor args = t.to(torch::kFloat32).unsqueeze(1) * freqs.unsqueeze(0);
  return torch::cat({args.sin(), args.cos()}, 1);
}

torch::Tensor upsample(torch::nn::ConvTranspose1dImpl& up, const torch::Tensor& x) {
  const auto& o = up.options;
  if ((*o.kernel_size())[0] != 4 || (*o.stride())[0] != 2 || (*c10::get<torch::ExpandingArray<1>>(o.padding()))[0] != 1 ||
      (*o.output_padding())[0] != 0 || o.groups() != 1)
    return up.forward(x);
  // ConvTranspose1d(k 4, s 2, p 1) as one Conv1d(k 3, p 1) with both output phases as channels:
  // even outputs 2m take taps 3 and 1 of x[m - 1] and x[m], odd outputs 2m + 1 taps 2 and 0 of x[m]
  // and x[m + 1]. libtorch runs transposed convolutions sample by sample on this CPU; this runs on
  // oneDNN like the other convolutions (tests/test_fast_paths.cpp checks the two agree).
  const torch::Tensor w = up.weight.permute({1, 0, 2});  // (out, in, 4)
  const torch::Tensor zero = torch::zeros_like(w.select(2, 0));
  const torch::Tensor even = torch::stack({w.select(2, 3), w.select(2, 1), zero}, 2);
  const torch::Tensor odd = torch::stack({zero, w.select(2, 2), w.select(2, 0)}, 2);
  const torch::Tensor y = torch::conv1d(x, torch::cat({even, odd}, 0), torch::cat({up.bias, up.bias}), 1, 1);
  const int64_t B = x.size(0), C = w.size(0), T = x.size(2);
  return y.view({B, 2, C, T}).permute({0, 2, 3, 1}).reshape({B, C, 2 * T});
}

Conv1dBlockImpl::Conv1dBlockImpl(int in, int out, int kernel, int groups) {
  conv = register_module("conv", torch::nn::Conv1d(torch::nn::Conv1dOptions(in, out, kernel).padding(kernel / 2)));
  norm = register_module("norm", torch::nn::GroupNorm(torch::nn::GroupNormOptions(groups, out)));
}

torch::Tensor Conv1dBlockImpl::forward(const torch::Tensor& x) { return nn::mish(norm(conv(x))); }

ResBlockImpl::ResBlockImpl(int in, int out, int cond_dim, int kernel, int groups) : out_channels(out) {
  block0 = register_module("block0", Conv1dBlock(in, out, kernel, groups));
  block1 = register_module("block1", Conv1dBlock(out, out, kernel, groups));
  film_proj = register_module("film", torch::nn::Linear(cond_dim, 2 * out));
  if (in != out) residual = register_module("residual", torch::nn::Conv1d(torch::nn::Conv1dOptions(in, out, 1)));
}

torch::Tensor ResBlockImpl::film(const torch::Tensor& cond) { return film_proj(nn::mish(cond)); }

torch::Tensor ResBlockImpl::forward(const torch::Tensor& x, const torch::Tensor& film) {
  torch::Tensor h = block0(x);
  const torch::Tensor scale = film.narrow(1, 0, out_channels).unsqueeze(-1);
  const torch::Tensor bias = film.narrow(1, out_channels, out_channels).unsqueeze(-1);
  h = block1(torch::addcmul(bias, scale, h));
  return h + (residual ? residual(x) : x);
}

ConditionalUnet1DImpl::ConditionalUnet1DImpl(int action_dim, int global_cond_dim, const UnetConfig& config)
    : config_(config), cond_dim_(config.step_embed_dim + global_cond_dim) {
  const int e = config.step_embed_dim;
  step_fc1 = register_module("step_fc1", torch::nn::Linear(e, 4 * e));
  step_fc2 = register_module("step_fc2", torch::nn::Linear(4 * e, e));

  std::vector<int> dims{action_dim};
  dims.insert(dims.end(), config.down_dims.begin(), config.down_dims.end());
  const size_t levels = config.down_dims.size();
  for (size_t i = 0; i < levels; ++i) {
    const std::string p = "down" + std::to_string(i);
    Level l;
    l.first = add_res(p + "_res0", dims[i], dims[i + 1]);
    l.second = add_res(p + "_res1", dims[i + 1], dims[i + 1]);
    if (i + 1 < levels) {
      l.down = register_module(p + "_sample",
                               torch::nn::Conv1d(torch::nn::Conv1dOptions(dims[i + 1], dims[i + 1], 3).stride(2).padding(1)));
    }
    down_.push_back(l);
  }
  const int mid = config.down_dims.back();
  mid0_ = add_res("mid_res0", mid, mid);
  mid1_ = add_res("mid_res1", mid, mid);
  // Up path: levels-1 stages, each concatenating the skip of the matching down level and upsampling.
  // The first level's skip is left unused, as in the reference architecture.
  for (size_t i = levels - 1; i >= 1; --i) {
    const std::string p = "up" + std::to_string(levels - 1 - i);
    Level l;
    l.first = add_res(p + "_res0", 2 * dims[i + 1], dims[i]);
    l.second = add_res(p + "_res1", dims[i], dims[i]);
    l.up = register_module(p + "_sample", torch::nn::ConvTranspose1d(
                                              torch::nn::ConvTranspose1dOptions(dims[i], dims[i], 4).stride(2).padding(1)));
    up_.push_back(l);
  }
  const int start = config.down_dims.front();
  final_block_ = register_module("final_block", Conv1dBlock(start, start, config.kernel_size, config.n_groups));
  final_conv_ = register_module("final_conv", torch::nn::Conv1d(torch::nn::Conv1dOptions(start, action_dim, 1)));
}

int64_t parameter_count(int action_dim, int global_cond_dim, const UnetConfig& config) {
  // the constructor above, layer by layer
  const int64_t k = config.kernel_size, e = config.step_embed_dim, cond = e + global_cond_dim;
  const auto conv = [](int64_t in, int64_t out, int64_t kernel) { return in * out * kernel + out; };
  const auto linear = [](int64_t in, int64_t out) { return in * out + out; };
  const auto block = [&](int64_t in, int64_t out) { return conv(in, out, k) + 2 * out; };  // + GroupNorm's affine
  const auto res = [&](int64_t in, int64_t out) {
    return block(in, out) + block(out, out) + linear(cond, 2 * out) + (in != out ? conv(in, out, 1) : 0);
  };
  std::vector<int64_t> dims{action_dim};
  dims.insert(dims.end(), config.down_dims.begin(), config.down_dims.end());
  const size_t levels = config.down_dims.size();
  int64_t n = linear(e, 4 * e) + linear(4 * e, e);
  for (size_t i = 0; i < levels; ++i) {
    n += res(dims[i], dims[i + 1]) + res(dims[i + 1], dims[i + 1]);
    if (i + 1 < levels) n += conv(dims[i + 1], dims[i + 1], 3);
  }
  n += 2 * res(dims.back(), dims.back());
  for (size_t i = levels - 1; i >= 1; --i) n += res(2 * dims[i + 1], dims[i]) + res(dims[i], dims[i]) + conv(dims[i], dims[i], 4);
  const int64_t start = config.down_dims.front();
  return n + block(start, start) + conv(start, action_dim, 1);
}

ResBlock ConditionalUnet1DImpl::add_res(const std::string& name, int in, int out) {
  ResBlock r = register_module(name, ResBlock(in, out, cond_dim_, config_.kernel_size, config_.n_groups));
  all_res_.push_back(r);
  return r;
}

torch::Tensor ConditionalUnet1DImpl::condition(const torch::Tensor& t, const torch::Tensor& global_cond) {
  const torch::Tensor emb = step_fc2(nn::mish(step_fc1(sinusoidal_embedding(t, config_.step_embed_dim))));
  return torch::cat({emb, global_cond}, 1);
}

std::vector<torch::Tensor> ConditionalUnet1DImpl::film(const torch::Tensor& cond) {
  std::vector<torch::Tensor> out;
  out.reserve(all_res_.size());
  for (auto& r : all_res_) out.push_back(r->film(cond));
  return out;
}

torch::Tensor ConditionalUnet1DImpl::denoise(const torch::Tensor& x, const std::vector<torch::Tensor>& films) {
  size_t k = 0;  // index into films, in the order add_res registered the blocks
  torch::Tensor h = x.transpose(1, 2);  // (B, A, T)
  std::vector<torch::Tensor> skips;
  for (auto& l : down_) {
    h = l.first(h, films[k++]);
    h = l.second(h, films[k++]);
    skips.push_back(h);
    if (l.down) h = l.down(h);
  }
  h = mid0_(h, films[k++]);
  h = mid1_(h, films[k++]);
  for (auto& l : up_) {
    h = torch::cat({h, skips.back()}, 1);
    skips.pop_back();
    h = l.first(h, films[k++]);
    h = l.second(h, films[k++]);
    h = upsample(*l.up, h);
  }
  h = final_conv_(final_block_(h));
  return h.transpose(1, 2);
}

torch::Tensor ConditionalUnet1DImpl::forward(const torch::Tensor& x, const torch::Tensor& t,
                                             const torch::Tensor& global_cond) {
  return denoise(x, film(condition(t, global_cond)));
}

}  // namespace dd::nn
