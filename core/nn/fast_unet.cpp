#include "core/nn/fast_unet.h"

#include "core/nn/bf16_gemm.h"
#include "core/nn/mish.h"

#include <Eigen/Core>

#include <algorithm>
#include <cmath>


// OpenBLAS (the BLAS libtorch runs on, see quickstart.sh) through its standard C interface,
// declared here so the build needs no particular cblas.h.
extern "C" void cblas_sgemm(int order, int trans_a, int trans_b, int m, int n, int k, float alpha, const float* a, int lda,
                            const float* b, int ldb, float beta, float* c, int ldc);

namespace dd::nn {
namespace {

constexpr int kRowMajor = 101, kNoTrans = 111, kTrans = 112;

const float* data_of(const torch::Tensor& t) {
  if (!t.defined()) return nullptr;
  if (t.scalar_type() != torch::kFloat32 || !t.is_contiguous() || !t.device().is_cpu())
    throw Error("fast denoiser: expected contiguous float32 CPU weights");
  return t.data_ptr<float>();
}

int padding_of(const torch::nn::detail::conv_padding_t<1>& p) {
  if (const auto* a = c10::get_if<torch::ExpandingArray<1>>(&p)) return static_cast<int>((**a)[0]);
  throw Error("fast denoiser: only explicit convolution padding is supported");
}

}  // namespace

FastDenoiser::Conv FastDenoiser::conv_of(const torch::nn::Conv1dImpl& m) {
  const auto& o = m.options;
  return {data_of(m.weight), data_of(m.bias), static_cast<int>(o.in_channels()), static_cast<int>(o.out_channels()),
          static_cast<int>((*o.kernel_size())[0]), static_cast<int>((*o.stride())[0]), padding_of(o.padding())};
}

FastDenoiser::Conv FastDenoiser::conv_of(const torch::nn::ConvTranspose1dImpl& m) {
  const auto& o = m.options;
  if ((*o.output_padding())[0] != 0 || (*o.dilation())[0] != 1 || o.groups() != 1)
    throw Error("fast denoiser: transposed convolution options beyond stride and padding");
  return {data_of(m.weight), data_of(m.bias), static_cast<int>(o.in_channels()), static_cast<int>(o.out_channels()),
          static_cast<int>((*o.kernel_size())[0]), static_cast<int>((*o.stride())[0]), padding_of(o.padding())};
}

FastDenoiser::Block FastDenoiser::block_of(const Conv1dBlockImpl& m) {
  const auto& n = *m.norm;
  return {conv_of(*m.conv),
          {data_of(n.weight), data_of(n.bias), static_cast<int>(n.options.num_groups()), static_cast<float>(n.options.eps())}};
}

FastDenoiser::Res FastDenoiser::res_of(const ResBlockImpl& m) {
  Res r{block_of(*m.block0), block_of(*m.block1), {}};
  if (m.residual) r.residual = conv_of(*m.residual);
  return r;
}

FastDenoiser::FastDenoiser(const ConditionalUnet1DImpl& net, Precision precision) : precision_(precision) {
  for (const auto& l : net.down_)
    down_.push_back({res_of(*l.first), res_of(*l.second), l.down ? conv_of(*l.down) : Conv{}});
  mid0_ = res_of(*net.mid0_);
  mid1_ = res_of(*net.mid1_);
  for (const auto& l : net.up_) up_.push_back({res_of(*l.first), res_of(*l.second), conv_of(*l.up)});
  final_block_ = block_of(*net.final_block_);
  final_conv_ = conv_of(*net.final_conv_);
  action_dim_ = final_conv_.out;
  if (precision_ == Precision::kBFloat16) {
    if (!have_bf16_gemm()) throw Error("fast denoiser: bfloat16 needs oneDNN's bf16 matmul (a build with libdnnl-dev, on a CPU with AVX-512)");
    convert_weights();
  }
}

void FastDenoiser::convert_weights() {
  auto convert = [&](Conv& c, bool transposed) {
    if (!c.w) return;
    const int64_t n = static_cast<int64_t>(c.in) * c.out * c.k;
    std::vector<uint16_t>& w = bf16_.emplace_back(static_cast<size_t>(n));
    if (!transposed) {
      to_bf16(c.w, n, w.data());
    } else {  // (in, out k) -> (out k, in)
      const int cols = c.out * c.k;
      std::vector<float> t(static_cast<size_t>(n));
      for (int i = 0; i < c.in; ++i)
        for (int j = 0; j < cols; ++j) t[static_cast<size_t>(j) * c.in + i] = c.w[static_cast<size_t>(i) * cols + j];
      to_bf16(t.data(), n, w.data());
    }
    c.w16 = w.data();
  };
  auto res = [&](Res& r) {
    convert(r.b0.conv, false);
    convert(r.b1.conv, false);
    convert(r.residual, false);
  };
  // Conv::w16 points into bf16_'s elements, whose buffers stay put when bf16_ grows
  for (Level& l : down_) {
    res(l.first);
    res(l.second);
    convert(l.resample, false);
  }
  res(mid0_);
  res(mid1_);
  for (Level& l : up_) {
    res(l.first);
    res(l.second);
    convert(l.resample, true);
  }
  convert(final_block_.conv, false);
  convert(final_conv_, false);
}

namespace {

// `n` floats as bfloat16 bits in `buf` (resized to fit); returns buf's data.
const uint16_t* converted(const float* x, size_t n, std::vector<uint16_t>& buf) {
  buf.resize(n);
  to_bf16(x, static_cast<int64_t>(n), buf.data());
  return buf.data();
}

}  // namespace

void FastDenoiser::transposed_product(const Conv& c, int M, int N, int K, const float* B, float* C) const {
  if (!use_bf16(M, N, K)) {
    cblas_sgemm(kRowMajor, kTrans, kNoTrans, M, N, K, 1.f, c.w, M, B, N, 0.f, C, N);
    return;
  }
  thread_local std::vector<uint16_t> b16;
  gemm_bf16(M, N, K, c.w16, converted(B, static_cast<size_t>(K) * N, b16), C, false);
}

// Activations are (C, B T): row c holds channel c of every batch row, each row's T steps contiguous.

// out (C_out, B T_out) = W (C_out, C_in k) x im2col(x) (C_in k, B T_out) + b: torch's (out, in, k)
// weight is that matrix as stored, with im2col rows ordered (channel, tap).
namespace {

// im2col of a (C, B, T) activation into (C k, B T_out) columns, rows ordered (channel, tap); zero
// padding where a tap falls outside the row. T: float, or bfloat16 bits.
template <class T>
void im2col(const T* x, int in, int batch, int t_in, int k, int stride, int pad, int t_out, T* cols) {
  const size_t n = static_cast<size_t>(batch) * t_out;
  std::fill_n(cols, static_cast<size_t>(in) * k * n, T(0));
  for (int i = 0; i < in; ++i)
    for (int j = 0; j < k; ++j)
      for (int r = 0; r < batch; ++r) {
        T* dst = cols + (static_cast<size_t>(i) * k + j) * n + static_cast<size_t>(r) * t_out;
        const T* src = x + (static_cast<size_t>(i) * batch + r) * t_in;
        for (int t = 0; t < t_out; ++t) {
          const int s = t * stride + j - pad;
          if (s >= 0 && s < t_in) dst[t] = src[s];
        }
      }
}

}  // namespace

FastDenoiser::Act FastDenoiser::conv(const Act& x, const Conv& c) const {
  const int t_out = (x.t + 2 * c.pad - c.k) / c.stride + 1, n = x.b * t_out, K = c.in * c.k;
  Act y{c.out, x.b, t_out, std::vector<float>(static_cast<size_t>(c.out) * n)};
  for (int o = 0; o < c.out; ++o) std::fill_n(y.v.data() + static_cast<size_t>(o) * n, n, c.b[o]);
  const bool cols_needed = c.k != 1 || c.stride != 1 || c.pad != 0;
  if (use_bf16(c.out, n, K)) {
    // convert the activation once, then gather the columns in bfloat16: k times less to convert
    thread_local std::vector<uint16_t> x16, cols16;
    const uint16_t* b = converted(x.v.data(), x.v.size(), x16);
    if (cols_needed) {
      cols16.resize(static_cast<size_t>(K) * n);
      im2col(b, c.in, x.b, x.t, c.k, c.stride, c.pad, t_out, cols16.data());
      b = cols16.data();
    }
    gemm_bf16(c.out, n, K, c.w16, b, y.v.data(), true);
    return y;
  }
  const float* b = x.v.data();
  std::vector<float> cols;
  if (cols_needed) {
    cols.resize(static_cast<size_t>(K) * n);
    im2col(x.v.data(), c.in, x.b, x.t, c.k, c.stride, c.pad, t_out, cols.data());
    b = cols.data();
  }
  cblas_sgemm(kRowMajor, kNoTrans, kNoTrans, c.out, n, K, 1.f, c.w, K, b, n, 1.f, y.v.data(), n);
  return y;
}

// Y (C_out k, B T) = W^T x with torch's (in, out, k) weight read as an (in, out k) matrix; each input
// step t then adds tap j of Y into output step t * stride - pad + j of the same batch row.
FastDenoiser::Act FastDenoiser::conv_transpose(const Act& x, const Conv& c) const {
  const int t_out = (x.t - 1) * c.stride - 2 * c.pad + c.k, n = x.b * x.t;
  std::vector<float> cols(static_cast<size_t>(c.out) * c.k * n);
  transposed_product(c, c.out * c.k, n, c.in, x.v.data(), cols.data());
  Act y{c.out, x.b, t_out, std::vector<float>(static_cast<size_t>(c.out) * x.b * t_out)};
  for (int o = 0; o < c.out; ++o)
    for (int r = 0; r < x.b; ++r) {
      float* dst = y.v.data() + (static_cast<size_t>(o) * x.b + r) * t_out;
      std::fill_n(dst, t_out, c.b[o]);
      for (int j = 0; j < c.k; ++j) {
        const float* row = cols.data() + (static_cast<size_t>(o) * c.k + j) * n + static_cast<size_t>(r) * x.t;
        for (int t = 0; t < x.t; ++t) {
          const int d = t * c.stride - c.pad + j;
          if (d >= 0 && d < t_out) dst[d] += row[t];
        }
      }
    }
  return y;
}

// GroupNorm (biased variance over each batch row's group of channels and steps), then Mish, in place.
void FastDenoiser::norm_mish(Act& h, const Norm& n) {
  const int per = h.c / n.groups;
  const size_t row = static_cast<size_t>(h.b) * h.t;  // one channel's values
  for (int r = 0; r < h.b; ++r)
    for (int g = 0; g < n.groups; ++g) {
      double sum = 0, sq = 0;
      for (int i = 0; i < per; ++i) {
        const Eigen::Map<const Eigen::ArrayXf> a(h.v.data() + (g * per + i) * row + static_cast<size_t>(r) * h.t, h.t);
        sum += a.cast<double>().sum();
        sq += a.cast<double>().square().sum();
      }
      const double count = static_cast<double>(per) * h.t, mean = sum / count;
      const float inv = static_cast<float>(1.0 / std::sqrt(std::max(sq / count - mean * mean, 0.0) + n.eps));
      for (int i = 0; i < per; ++i) {
        const int ch = g * per + i;
        const float s = n.gamma[ch] * inv, b = n.beta[ch] - static_cast<float>(mean) * s;
        Eigen::Map<Eigen::ArrayXf> a(h.v.data() + ch * row + static_cast<size_t>(r) * h.t, h.t);
        a = a * s + b;
      }
    }
  mish_inplace(h.v.data(), static_cast<int64_t>(h.v.size()));
}

FastDenoiser::Act FastDenoiser::res(const Act& x, const Res& r, const Film& film) const {
  Act h = block(x, r.b0);
  const int c = h.c;
  for (int ch = 0; ch < c; ++ch)
    for (int b = 0; b < h.b; ++b) {
      const float* f = film.data + static_cast<size_t>(b) * film.stride;
      const float scale = f[ch], bias = f[c + ch];
      float* row = h.v.data() + (static_cast<size_t>(ch) * h.b + b) * h.t;
      for (int t = 0; t < h.t; ++t) row[t] = bias + scale * row[t];
    }
  h = block(h, r.b1);
  if (r.residual.w) {
    const Act skip = conv(x, r.residual);
    for (size_t i = 0; i < h.v.size(); ++i) h.v[i] += skip.v[i];
  } else {
    for (size_t i = 0; i < h.v.size(); ++i) h.v[i] += x.v[i];
  }
  return h;
}

void FastDenoiser::denoise(const float* x, int batch, int horizon, const std::vector<Film>& films, float* out) const {
  // Blocks of rows small enough that a block's im2col buffers stay in cache.
  const int per_block = std::max(1, static_cast<int>(kColumnsPerBlock / horizon));
  const size_t chunk = static_cast<size_t>(horizon) * action_dim_;
  std::vector<Film> rows(films.size());
  for (int b0 = 0; b0 < batch; b0 += per_block) {
    for (size_t k = 0; k < films.size(); ++k) rows[k] = {films[k].data + b0 * films[k].stride, films[k].stride};
    denoise_block(x + b0 * chunk, std::min(per_block, batch - b0), horizon, rows, out + b0 * chunk);
  }
}

void FastDenoiser::denoise_block(const float* x, int batch, int horizon, const std::vector<Film>& films, float* out) const {
  const int A = action_dim_;
  Act h{A, batch, horizon, std::vector<float>(static_cast<size_t>(A) * batch * horizon)};
  for (int b = 0; b < batch; ++b)  // (B, T_p, A) row-major in, channel-major (A, B T_p) inside
    for (int t = 0; t < horizon; ++t)
      for (int a = 0; a < A; ++a)
        h.v[(static_cast<size_t>(a) * batch + b) * horizon + t] = x[(static_cast<size_t>(b) * horizon + t) * A + a];
  size_t k = 0;  // films in the order ConditionalUnet1DImpl::film gives them
  std::vector<Act> skips;
  for (const Level& l : down_) {
    h = res(h, l.first, films[k++]);
    h = res(h, l.second, films[k++]);
    skips.push_back(h);
    if (l.resample.w) h = conv(h, l.resample);
  }
  h = res(h, mid0_, films[k++]);
  h = res(h, mid1_, films[k++]);
  for (const Level& l : up_) {
    const Act& skip = skips.back();  // channel concatenation: h's channels, then the skip's
    h.v.insert(h.v.end(), skip.v.begin(), skip.v.end());
    h.c += skip.c;
    skips.pop_back();
    h = res(h, l.first, films[k++]);
    h = res(h, l.second, films[k++]);
    h = conv_transpose(h, l.resample);
  }
  h = conv(block(h, final_block_), final_conv_);
  for (int b = 0; b < batch; ++b)
    for (int t = 0; t < horizon; ++t)
      for (int a = 0; a < A; ++a)
        out[(static_cast<size_t>(b) * horizon + t) * A + a] = h.v[(static_cast<size_t>(a) * batch + b) * horizon + t];
}

torch::Tensor FastDenoiser::denoise(const torch::Tensor& x, const std::vector<torch::Tensor>& films) const {
  const torch::Tensor xc = x.contiguous();
  torch::Tensor out = torch::empty_like(xc);
  std::vector<torch::Tensor> fc;
  std::vector<Film> rows;
  for (const auto& f : films) {
    fc.push_back(f.contiguous());
    rows.push_back({fc.back().data_ptr<float>(), fc.back().size(1)});
  }
  denoise(xc.data_ptr<float>(), static_cast<int>(xc.size(0)), static_cast<int>(xc.size(1)), rows, out.data_ptr<float>());
  return out;
}

}  // namespace dd::nn
