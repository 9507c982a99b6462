#include "core/nn/mish.h"

#include <ATen/Parallel.h>

#include <atomic>

#include <Eigen/Core>

namespace dd::nn {
namespace {

// With n = e^x: tanh(softplus(x)) = q / (q + 2), q = n (n + 2); sigmoid(x) = n / (n + 1). Above
// x = 20 both are 1 in float, so x is capped there before the exponential.
using Array = Eigen::Map<Eigen::ArrayXf>;
using ConstArray = Eigen::Map<const Eigen::ArrayXf>;
constexpr int64_t kGrain = 1 << 14;
std::atomic<bool> fused{true};

torch::Tensor forward_kernel(const torch::Tensor& input) {
  torch::Tensor y = input.contiguous().clone();
  float* yp = y.data_ptr<float>();
  at::parallel_for(0, y.numel(), kGrain, [&](int64_t begin, int64_t end) { mish_inplace(yp + begin, end - begin); });
  return y;
}

torch::Tensor backward_kernel(const torch::Tensor& grad, const torch::Tensor& input) {
  const torch::Tensor x = input.contiguous(), g = grad.contiguous();
  torch::Tensor out = torch::empty_like(x);
  const float *xp = x.data_ptr<float>(), *gp = g.data_ptr<float>();
  float* op = out.data_ptr<float>();
  at::parallel_for(0, x.numel(), kGrain, [&](int64_t begin, int64_t end) {
    const ConstArray a(xp + begin, end - begin), ga(gp + begin, end - begin);
    const Eigen::ArrayXf n = a.min(20.f).exp();
    const Eigen::ArrayXf q = n * (n + 2.f);
    const Eigen::ArrayXf t = q / (q + 2.f);  // tanh(softplus(x))
    // d/dx x tanh(sp(x)) = tanh(sp) + x (1 - tanh(sp)^2) sigmoid(x)
    Array(op + begin, end - begin) = ga * (t + a * (1.f - t * t) * (n / (n + 1.f)));
  });
  return out;
}

struct MishFunction : torch::autograd::Function<MishFunction> {
  static torch::Tensor forward(torch::autograd::AutogradContext* ctx, const torch::Tensor& x) {
    ctx->save_for_backward({x});
    return forward_kernel(x);
  }
  static torch::autograd::tensor_list backward(torch::autograd::AutogradContext* ctx, torch::autograd::tensor_list grads) {
    return {backward_kernel(grads[0], ctx->get_saved_variables()[0])};
  }
};

}  // namespace

void mish_inplace(float* x, int64_t n) {
  Array a(x, n);
  const Eigen::ArrayXf e = a.min(20.f).exp();
  const Eigen::ArrayXf q = e * (e + 2.f);
  a = a * q / (q + 2.f);
}

void set_fused_mish(bool on) { fused = on; }

torch::Tensor mish(const torch::Tensor& x) {
  if (!fused || x.scalar_type() != torch::kFloat32 || !x.device().is_cpu()) return torch::mish(x);
  if (torch::GradMode::is_enabled() && x.requires_grad()) return MishFunction::apply(x);
  return forward_kernel(x);
}

}  // namespace dd::nn
