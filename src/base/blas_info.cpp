// The BLAS/LAPACK kfx runs on (kfx/blas_info.hpp): library query, DGEMM rate, kernel self-test.
// No Eigen here: Eigen's EIGEN_USE_BLAS header declares dgemm_ with another return type.
#include <dlfcn.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstddef>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "kfx/blas_info.hpp"
#include "kfx/error.hpp"

extern "C" {
// OpenBLAS's query functions, weak: null when the BLAS in the process is another one.
char* openblas_get_config(void) __attribute__((weak));
char* openblas_get_corename(void) __attribute__((weak));
int openblas_get_num_threads(void) __attribute__((weak));
// Reference BLAS/LAPACK (gfortran conventions, src/base/lapack_fortran.hpp), weak as well for ILAVER.
void dgemm_(const char* ta, const char* tb, const int* m, const int* n, const int* k, const double* alpha,
            const double* a, const int* lda, const double* b, const int* ldb, const double* beta, double* c,
            const int* ldc, std::size_t, std::size_t);
void dsymv_(const char* uplo, const int* n, const double* alpha, const double* a, const int* lda, const double* x,
            const int* incx, const double* beta, double* y, const int* incy, std::size_t);
void dgetrf_(const int* m, const int* n, double* a, const int* lda, int* ipiv, int* info);
void ilaver_(int* major, int* minor, int* patch) __attribute__((weak));
}

namespace kfx {
namespace {

std::string LibraryOf(const void* symbol) {
  Dl_info info{};
  if (symbol == nullptr || dladdr(symbol, &info) == 0 || info.dli_fname == nullptr) return "";
  return info.dli_fname;
}

// C = alpha op(A) op(B) + beta C by loops, with the bound sum |alpha a b| + |beta c| of each entry.
void ReferenceGemm(char ta, char tb, int m, int n, int k, double alpha, const std::vector<double>& a, int lda,
                   const std::vector<double>& b, int ldb, double beta, std::vector<double>* c,
                   std::vector<double>* bound) {
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < m; ++i) {
      long double s = 0, abs_sum = 0;
      for (int l = 0; l < k; ++l) {
        const double x = ta == 'N' ? a[i + l * lda] : a[l + i * lda];
        const double y = tb == 'N' ? b[l + j * ldb] : b[j + l * ldb];
        s += static_cast<long double>(x) * y;
        abs_sum += std::fabs(static_cast<long double>(x) * y);
      }
      double& cij = (*c)[i + j * m];
      (*bound)[i + j * m] = static_cast<double>(std::fabs(alpha) * abs_sum + std::fabs(beta * cij));
      cij = static_cast<double>(alpha * s + beta * cij);
    }
}

// Largest |got - want| / (64 k eps bound + tiny) over the entries.
double WorstError(const std::vector<double>& got, const std::vector<double>& want, const std::vector<double>& bound,
                  int k) {
  const double eps = std::numeric_limits<double>::epsilon();
  double worst = 0;
  for (std::size_t i = 0; i < got.size(); ++i) {
    const double tol = 64.0 * std::max(k, 1) * eps * bound[i] + std::numeric_limits<double>::min();
    const double e = std::fabs(got[i] - want[i]) / tol;
    worst = std::isfinite(e) ? std::max(worst, e) : std::numeric_limits<double>::infinity();
  }
  return worst;
}

double CheckGemm(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  double worst = 0;
  const int sizes[] = {1, 2, 3, 5, 8, 13, 24, 33, 47};
  for (char ta : {'N', 'T'})
    for (char tb : {'N', 'T'})
      for (int s : sizes) {
        const int m = s, n = std::max(1, s - 1), k = s + 2;
        const int lda = (ta == 'N' ? m : k) + 1, ldb = (tb == 'N' ? k : n) + 2;
        std::vector<double> a(static_cast<std::size_t>(lda) * (ta == 'N' ? k : m));
        std::vector<double> b(static_cast<std::size_t>(ldb) * (tb == 'N' ? n : k));
        std::vector<double> c(static_cast<std::size_t>(m) * n), bound(c.size());
        for (auto* v : {&a, &b, &c})
          for (double& x : *v) x = u(rng);
        std::vector<double> want = c;
        const double alpha = 0.75, beta = -0.5;
        ReferenceGemm(ta, tb, m, n, k, alpha, a, lda, b, ldb, beta, &want, &bound);
        dgemm_(&ta, &tb, &m, &n, &k, &alpha, a.data(), &lda, b.data(), &ldb, &beta, c.data(), &m, 1, 1);
        worst = std::max(worst, WorstError(c, want, bound, k));
      }
  return worst;
}

double CheckSymv(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  double worst = 0;
  for (char uplo : {'L', 'U'})
    for (int n = 1; n <= 33; n += (n < 9 ? 1 : 8)) {
      const int lda = n + 3, inc = 1;
      std::vector<double> a(static_cast<std::size_t>(lda) * n), x(n), y(n);
      for (auto* v : {&a, &x, &y})
        for (double& e : *v) e = u(rng);
      std::vector<double> full(static_cast<std::size_t>(n) * n);  // the symmetric matrix the triangle means
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
          const bool stored = uplo == 'L' ? i >= j : i <= j;
          full[i + j * n] = stored ? a[i + j * lda] : a[j + i * lda];
        }
      std::vector<double> want = y, bound(n);
      const double alpha = 1.25, beta = 0.5;
      ReferenceGemm('N', 'N', n, 1, n, alpha, full, n, x, n, beta, &want, &bound);
      dsymv_(&uplo, &n, &alpha, a.data(), &lda, x.data(), &inc, &beta, y.data(), &inc, 1);
      worst = std::max(worst, WorstError(y, want, bound, n));
    }
  return worst;
}

}  // namespace

BlasInfo QueryBlasInfo() {
  BlasInfo info;
  info.blas_library = LibraryOf(reinterpret_cast<const void*>(&dgemm_));
  info.lapack_library = LibraryOf(reinterpret_cast<const void*>(&dgetrf_));
  if (ilaver_ != nullptr) {
    int major = 0, minor = 0, patch = 0;
    ilaver_(&major, &minor, &patch);
    info.lapack_version = std::to_string(major) + "." + std::to_string(minor) + "." + std::to_string(patch);
  }
  info.openblas = openblas_get_corename != nullptr;
  if (openblas_get_config != nullptr && openblas_get_config() != nullptr) info.config = openblas_get_config();
  if (openblas_get_corename != nullptr && openblas_get_corename() != nullptr) info.core_name = openblas_get_corename();
  if (openblas_get_num_threads != nullptr) info.threads = openblas_get_num_threads();
  return info;
}

double MeasureDgemmRate(int n, double seconds) {
  if (n < 1) throw Error("MeasureDgemmRate: n must be >= 1, got " + std::to_string(n));
  if (!(seconds > 0 && seconds <= 60))
    throw Error("MeasureDgemmRate: seconds must be in (0, 60], got " + std::to_string(seconds));
  std::mt19937_64 rng(24);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const std::size_t nn = static_cast<std::size_t>(n) * n;
  std::vector<double> a(nn), b(nn), c(nn, 0.0);
  for (std::size_t i = 0; i < nn; ++i) a[i] = u(rng), b[i] = u(rng);
  const double one = 1.0, zero = 0.0;
  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  double best = std::numeric_limits<double>::infinity();
  for (int call = 0;; ++call) {
    const auto t0 = Clock::now();
    dgemm_("N", "N", &n, &n, &n, &one, a.data(), &n, b.data(), &n, &zero, c.data(), &n, 1, 1);
    const auto t1 = Clock::now();
    if (call > 0) best = std::min(best, std::chrono::duration<double>(t1 - t0).count());  // call 0 warms up
    if (call >= 2 && std::chrono::duration<double>(t1 - start).count() >= seconds) break;
  }
  best = std::max(best, 1e-9);  // a clock tick: keeps the rate finite
  return 2.0 * n * static_cast<double>(n) * n / best * 1e-9;
}

bool CheckBlasKernel(double* max_error) {
  std::mt19937_64 rng(20241);
  const double worst = std::max(CheckGemm(rng), CheckSymv(rng));
  if (max_error != nullptr) *max_error = worst;
  return worst <= 1.0;
}

}  // namespace kfx
