// C (M x N, float32) = A (M x K) B (K x N) with bfloat16 operands and float32 accumulation, through
// oneDNN's matmul (AVX-512 BF16 where the CPU has it; oneDNN emulates it otherwise). Row-major,
// dense. The lower-precision option of nn::FastDenoiser (never the default; its cost in agreement
// with float32 is measured by tests/bench/precision_agreement).
#pragma once

#include <cstdint>
#include <vector>

namespace dd::nn {

/// Whether bfloat16 products can run here: a build with oneDNN (libdnnl-dev) on a CPU that oneDNN
/// has bf16 kernels for (AVX-512); otherwise the bfloat16 option is refused.
bool have_bf16_gemm();

/// float32 -> bfloat16 with round-to-nearest-even (NaN stays NaN). Hand-written: five lines of bit
/// arithmetic, cheaper than a oneDNN reorder primitive per shape.
void to_bf16(const float* src, int64_t n, uint16_t* dst);

/// C = A B (accumulate: C += A B). Primitives are cached per shape, per thread.
void gemm_bf16(int M, int N, int K, const uint16_t* A, const uint16_t* B, float* C, bool accumulate);

}  // namespace dd::nn
