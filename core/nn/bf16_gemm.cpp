#include "core/nn/bf16_gemm.h"

#include <cstring>
#include <map>
#include <tuple>

#include "core/config.h"

#ifdef DD_HAVE_DNNL
#include <dnnl.hpp>
#endif

namespace dd::nn {

// Branch-free, so the compiler vectorises it; one clone per instruction set, chosen at load time.
// One clone per instruction set, chosen at load time by an ifunc resolver. Not under ThreadSanitizer:
// it instruments the resolver, which runs before its runtime has started (a crash at load).
#if defined(__SANITIZE_THREAD__)
#define DD_TARGET_CLONES
#else
#define DD_TARGET_CLONES __attribute__((target_clones("avx512f", "avx2", "default")))
#endif
DD_TARGET_CLONES void to_bf16(const float* src, int64_t n, uint16_t* dst) {
  for (int64_t i = 0; i < n; ++i) {
    uint32_t u;
    std::memcpy(&u, &src[i], 4);
    const uint32_t nan = static_cast<uint32_t>((u & 0x7FFFFFFFu) > 0x7F800000u);
    const uint32_t rounded = (u + 0x7FFFu + ((u >> 16) & 1u)) >> 16;
    const uint32_t quiet = (u >> 16) | 0x40u;
    dst[i] = static_cast<uint16_t>(nan ? quiet : rounded);
  }
}

#ifdef DD_HAVE_DNNL
namespace {

struct Gemm {
  dnnl::matmul mm;
  dnnl::memory::desc a, b, c;
};

struct Engine {
  dnnl::engine eng{dnnl::engine::kind::cpu, 0};
  dnnl::stream stream{eng};
  std::map<std::tuple<int, int, int, bool>, Gemm> cache;
};

Engine& engine() {
  thread_local Engine e;
  return e;
}

}  // namespace

// oneDNN 2.6 has bf16 matmul kernels only for AVX-512 CPUs (native BF16, or emulated on AVX-512
// core); on others creating the primitive fails. Asked once, with a 1 x 1 x 1 product.
bool have_bf16_gemm() {
  static const bool available = [] {
    try {
      using dt = dnnl::memory::data_type;
      using tag = dnnl::memory::format_tag;
      const dnnl::engine eng(dnnl::engine::kind::cpu, 0);
      const dnnl::memory::desc a({1, 1}, dt::bf16, tag::ab), b({1, 1}, dt::bf16, tag::ab), c({1, 1}, dt::f32, tag::ab);
      dnnl::matmul::primitive_desc(dnnl::matmul::desc(a, b, c), eng);
      return true;
    } catch (const dnnl::error&) {
      return false;
    }
  }();
  return available;
}

void gemm_bf16(int M, int N, int K, const uint16_t* A, const uint16_t* B, float* C, bool accumulate) {
  using dt = dnnl::memory::data_type;
  using tag = dnnl::memory::format_tag;
  Engine& e = engine();
  auto it = e.cache.find({M, N, K, accumulate});
  if (it == e.cache.end()) {
    Gemm g;
    g.a = dnnl::memory::desc({M, K}, dt::bf16, tag::ab);
    g.b = dnnl::memory::desc({K, N}, dt::bf16, tag::ab);
    g.c = dnnl::memory::desc({M, N}, dt::f32, tag::ab);
    dnnl::primitive_attr attr;
    if (accumulate) {
      dnnl::post_ops ops;
      ops.append_sum(1.f);
      attr.set_post_ops(ops);
    }
    g.mm = dnnl::matmul(dnnl::matmul::primitive_desc(dnnl::matmul::desc(g.a, g.b, g.c), attr, e.eng));
    it = e.cache.emplace(std::make_tuple(M, N, K, accumulate), std::move(g)).first;
  }
  const Gemm& g = it->second;
  dnnl::memory a(g.a, e.eng, const_cast<uint16_t*>(A)), b(g.b, e.eng, const_cast<uint16_t*>(B)), c(g.c, e.eng, C);
  g.mm.execute(e.stream, {{DNNL_ARG_SRC, a}, {DNNL_ARG_WEIGHTS, b}, {DNNL_ARG_DST, c}});
  e.stream.wait();
}
#else
bool have_bf16_gemm() { return false; }

void gemm_bf16(int, int, int, const uint16_t*, const uint16_t*, float*, bool) {
  throw Error("bfloat16 inference: this build has no oneDNN (install libdnnl-dev and rebuild)");
}
#endif

}  // namespace dd::nn
