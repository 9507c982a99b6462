// Inference of ConditionalUnet1D's denoising pass without torch's per-operator dispatch.
//
// Sampling one chunk runs the U-Net T_d times at batch 1 on a (channels x T_p) activation of a few
// thousand values; there libtorch spends most of its time dispatching ~100 small operators per pass.
// This runs the same pass as a handful of OpenBLAS sgemm calls (convolutions as im2col products, the
// transposed convolution as a product and a scatter) and fused loops for GroupNorm, FiLM and Mish.
// Batches (the expected loss's N_b rows) run in blocks of rows whose buffers stay in cache, every
// row of a block in the same sgemm.
// It reads the module's weights in place, so build one per pass over a network (it holds pointers
// into the parameter tensors, which loading a checkpoint replaces); building it costs microseconds.
// Internal to core: includes torch through unet.h.
#pragma once

#include <cstdint>
#include <vector>

#include "core/nn/unet.h"

namespace dd::nn {

/// The arithmetic of the denoising pass's products: float32 (the default, sgemm), or bfloat16
/// operands with float32 accumulation (oneDNN; core/nn/bf16_gemm.h). Everything else stays float32.
enum class Precision { kFloat32, kBFloat16 };

class FastDenoiser {
 public:
  /// With kBFloat16 the weights are converted once here (about a millisecond for a million).
  explicit FastDenoiser(const ConditionalUnet1DImpl& net, Precision precision = Precision::kFloat32);
  FastDenoiser(const FastDenoiser&) = delete;
  FastDenoiser& operator=(const FastDenoiser&) = delete;

  /// FiLM rows of one residual block: scale then bias (2 C values) per batch row, `stride` apart.
  struct Film {
    const float* data = nullptr;
    int64_t stride = 0;
  };
  /// x is (batch, T_p, A) row-major; films[k] holds the k-th residual block's FiLM rows (in
  /// ConditionalUnet1DImpl::film's order); writes (batch, T_p, A) to out. Runs in blocks of rows.
  void denoise(const float* x, int batch, int horizon, const std::vector<Film>& films, float* out) const;

  /// The same on tensors: x (B, T_p, A) and films[k] (B, 2 C_k), float32.
  torch::Tensor denoise(const torch::Tensor& x, const std::vector<torch::Tensor>& films) const;

  static constexpr int64_t kColumnsPerBlock = 1024;  // batch rows x T_p per block
  /// bfloat16 only where it pays: products of at least this many columns (batch rows x steps), or
  /// with at least this many weights (rows x inner size). Below both, oneDNN's per-call cost outweighs
  /// its faster kernel (batch-1 sampling has 4-64 columns); with many weights, reading them is the
  /// cost, and bfloat16 halves it (the 64,128,256 network's middle and up blocks at batch 1).
  static constexpr int kBf16MinColumns = 256;
  static constexpr int64_t kBf16MinWeights = int64_t{1} << 17;

 private:
  struct Conv {
    const float* w = nullptr;  // (out, in, k) for a convolution, (in, out, k) for a transposed one
    const float* b = nullptr;
    int in = 0, out = 0, k = 1, stride = 1, pad = 0;
    const uint16_t* w16 = nullptr;  // bfloat16: (out, in k) for a convolution, (out k, in) for a transposed one
  };
  struct Norm {
    const float* gamma = nullptr;
    const float* beta = nullptr;
    int groups = 1;
    float eps = 1e-5f;
  };
  struct Block {  // Conv1d -> GroupNorm -> Mish
    Conv conv;
    Norm norm;
  };
  struct Res {
    Block b0, b1;
    Conv residual;  // w == nullptr: identity
  };
  struct Level {
    Res first, second;
    Conv resample;  // down: stride-2 convolution; up: transposed convolution; w == nullptr: none
  };

  /// A (C, B, T) activation, row-major: channel c's values for batch row b at v[(c B + b) T ...].
  struct Act {
    int c = 0, b = 0, t = 0;
    std::vector<float> v;
  };

  static Conv conv_of(const torch::nn::Conv1dImpl& m);
  static Conv conv_of(const torch::nn::ConvTranspose1dImpl& m);
  static Block block_of(const Conv1dBlockImpl& m);
  static Res res_of(const ResBlockImpl& m);

  bool use_bf16(int rows, int columns, int inner) const {
    return precision_ == Precision::kBFloat16 &&
           (columns >= kBf16MinColumns || static_cast<int64_t>(rows) * inner >= kBf16MinWeights);
  }
  /// C (M x N) = W^T B for a transposed convolution's (in, out k) weight W, B (K x N) float32.
  void transposed_product(const Conv& c, int M, int N, int K, const float* B, float* C) const;
  /// Gives every convolution its bfloat16 weights (kept in bf16_).
  void convert_weights();

  Act conv(const Act& x, const Conv& c) const;
  Act conv_transpose(const Act& x, const Conv& c) const;
  static void norm_mish(Act& h, const Norm& n);
  Act block(const Act& x, const Block& b) const {
    Act h = conv(x, b.conv);
    norm_mish(h, b.norm);
    return h;
  }
  Act res(const Act& x, const Res& r, const Film& film) const;
  /// One block of rows through the network.
  void denoise_block(const float* x, int batch, int horizon, const std::vector<Film>& films, float* out) const;

  std::vector<Level> down_, up_;
  Res mid0_, mid1_;
  Block final_block_;
  Conv final_conv_;
  int action_dim_ = 0;
  Precision precision_ = Precision::kFloat32;
  std::vector<std::vector<uint16_t>> bf16_;  // the weights' bfloat16 copies (Conv::w16 points here)
};

}  // namespace dd::nn
