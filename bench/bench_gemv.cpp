// Eigen's own matrix-vector kernel against OpenBLAS's DGEMV, single thread: where the two cost the same is
// kfx's threshold kEigenGemvMaxEntries (src/base/eigen_gemv.hpp; numbers in docs/benchmarks.md,
// "Matrix-vector products"). Arguments: rows, cols, transposed (0: y = A x, 1: y = A^T x). Both sides
// get the same DGEMV arguments (beta = 1, as Eigen's products pass them).
// Run: OPENBLAS_NUM_THREADS=1 ./build/bench/bench_gemv --benchmark_counters_tabular=true
#include <benchmark/benchmark.h>

#include <Eigen/Dense>
#include <cstddef>

#include "base/eigen_gemv.hpp"

#undef dgemv_  // the BLAS's own DGEMV (KFX_EIGEN_DEFINITIONS renames Eigen's calls to it)
extern "C" void dgemv_(const char* trans, const int* m, const int* n, const double* alpha, const double* a,
                       const int* lda, const double* x, const int* incx, const double* beta, double* y, const int* incy,
                       std::size_t trans_len);

namespace {

template <bool kBlas>
void BM_Gemv(benchmark::State& state) {
  const int m = static_cast<int>(state.range(0)), n = static_cast<int>(state.range(1));
  const char trans = state.range(2) != 0 ? 'T' : 'N';
  const Eigen::MatrixXd a = Eigen::MatrixXd::Random(m, n);
  const Eigen::VectorXd x = Eigen::VectorXd::Random(trans == 'N' ? n : m);
  Eigen::VectorXd y = Eigen::VectorXd::Zero(trans == 'N' ? m : n);
  const double alpha = 1e-9, beta = 1.0;  // small alpha: y stays bounded over the iterations
  const int inc = 1;
  for (auto _ : state) {
    if (kBlas) {
      dgemv_(&trans, &m, &n, &alpha, a.data(), &m, x.data(), &inc, &beta, y.data(), &inc, 1);
    } else {
      kfx::detail::EigenGemv(trans, m, n, alpha, a.data(), m, x.data(), inc, beta, y.data(), inc);
    }
    benchmark::DoNotOptimize(y.data());
    benchmark::ClobberMemory();
  }
  state.counters["entries"] = static_cast<double>(m) * n;
}

void Shapes(benchmark::internal::Benchmark* b) {
  for (const int t : {0, 1}) {
    for (const int n : {2, 4, 8, 16, 24, 32, 48, 64, 96, 128, 256}) b->Args({n, n, t});  // square
    for (const int m : {16, 64, 256, 1024, 4096}) b->Args({m, 4, t});                    // tall, 4 columns
    for (const int n : {16, 64, 256, 1024, 4096}) b->Args({4, n, t});                    // wide, 4 rows
  }
}

}  // namespace

BENCHMARK_TEMPLATE(BM_Gemv, false)->Name("eigen")->Apply(Shapes);
BENCHMARK_TEMPLATE(BM_Gemv, true)->Name("dgemv")->Apply(Shapes);
