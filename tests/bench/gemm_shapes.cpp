// Which GEMM for the denoising passes: OpenBLAS sgemm, oneDNN's f32 matmul and oneDNN's matmul with
// bf16 operands (f32 accumulation; this CPU has AVX-512 BF16), at the U-Net's shapes (out channels x
// in channels * kernel) x (in channels * kernel x columns): batch-1 sampling (columns = T, 4-16) and
// the expected loss's blocks (columns in the thousands). Prints microseconds per product.
//   OMP_NUM_THREADS=1 build/tests/bench/gemm_shapes
#include <dnnl.hpp>
#include <chrono>
#include <cstdio>
#include <unordered_map>
#include <vector>
extern "C" void cblas_sgemm(int order, int ta, int tb, int m, int n, int k, float alpha, const float* a, int lda, const float* b,
                            int ldb, float beta, float* c, int ldc);
enum { CblasRowMajor = 101, CblasNoTrans = 111 };
using namespace dnnl;
double bench(engine& eng, stream& s, int M, int K, int N, memory::data_type wt, int reps) {
  memory::desc a_md({M, K}, wt, memory::format_tag::ab), b_md({K, N}, wt, memory::format_tag::ab), c_md({M, N}, memory::data_type::f32, memory::format_tag::ab);
  matmul::primitive_desc pd(matmul::desc(a_md, b_md, c_md), eng);
  matmul mm(pd);
  memory A(a_md, eng), B(b_md, eng), C(c_md, eng);
  std::unordered_map<int, memory> args{{DNNL_ARG_SRC, A}, {DNNL_ARG_WEIGHTS, B}, {DNNL_ARG_DST, C}};
  for (int i = 0; i < 3; ++i) mm.execute(s, args);
  s.wait();
  auto t = std::chrono::steady_clock::now();
  for (int i = 0; i < reps; ++i) mm.execute(s, args);
  s.wait();
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count() / reps * 1e6;
}
double sgemm(int M, int K, int N, int reps) {
  std::vector<float> a(M * K, 0.1f), b(K * N, 0.2f), c(M * N);
  auto t = std::chrono::steady_clock::now();
  for (int i = 0; i < reps; ++i) cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, M, N, K, 1, a.data(), K, b.data(), N, 0, c.data(), N);
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count() / reps * 1e6;
}
int main() {
  engine eng(engine::kind::cpu, 0);
  stream s(eng);
  struct S { int M, K, N; } shapes[] = {{256, 1280, 4}, {128, 640, 8}, {64, 320, 16}, {128, 2560, 8}, {256, 1280, 256}, {64, 320, 8192}};
  for (auto sh : shapes) {
    const int reps = sh.N > 1000 ? 20 : 2000;
    std::printf("M %4d K %5d N %5d: sgemm %8.1f us  dnnl f32 %8.1f us  dnnl bf16 %8.1f us\n", sh.M, sh.K, sh.N, sgemm(sh.M, sh.K, sh.N, reps),
                bench(eng, s, sh.M, sh.K, sh.N, memory::data_type::f32, reps), bench(eng, s, sh.M, sh.K, sh.N, memory::data_type::bf16, reps));
  }
}
