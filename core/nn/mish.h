// Mish, x tanh(softplus(x)), forward and backward as one fused loop each with one exponential per
// element (Eigen's vectorised exp). libtorch 1.13's own kernels call exp, log1p and tanh per element
// and took a quarter of a training step (tests/bench/profile_train). Internal to core: includes torch.
#pragma once

#include <torch/torch.h>

namespace dd::nn {

/// Mish of a float32 tensor, differentiable (a custom autograd function that saves its input).
torch::Tensor mish(const torch::Tensor& x);

/// Mish of n floats in place, without autograd (the kernel mish() runs forward).
void mish_inplace(float* x, int64_t n);

/// Whether mish() uses the fused kernels (the default) or torch::mish: the benchmarks time both.
void set_fused_mish(bool on);

}  // namespace dd::nn
