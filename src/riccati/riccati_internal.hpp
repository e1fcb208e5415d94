#pragma once
// Private to the riccati layer (and the layers above that need the same LAPACK-backed primitives):
// small dense linear algebra shared by the DARE, the Lyapunov solver and the stability certificate.
#include <Eigen/Dense>
#include <climits>
#include <limits>
#include <vector>

#include "kfx/error.hpp"
#include "kfx/riccati.hpp"

namespace kfx::detail {

using ConstRef = Eigen::Ref<const Eigen::MatrixXd>;

/// "tiny" in the relative residuals: the smallest normal double.
constexpr double kTiny = std::numeric_limits<double>::min();
constexpr double kUnitRoundoff = 0.5 * std::numeric_limits<double>::epsilon();

/// A dimension as a Fortran integer (asserted to fit).
inline int FortranInt(Eigen::Index n) {
  KFX_ASSERT(n >= 0 && n <= static_cast<Eigen::Index>(INT_MAX));
  return static_cast<int>(n);
}

/// In-place 0.5 (M + M^T) without a temporary.
void SymmetrizeInPlace(Eigen::MatrixXd& m);

/// *out = beta * *out + alpha * A S A^T for symmetric S (only S's lower triangle is read), in 3 n^3
/// flops instead of two GEMMs' 4 n^3: with S = L + L^T (L the lower triangle of S, diagonal halved)
/// and B = A L (DTRMM, n^3), A S A^T = B A^T + A B^T (DSYR2K, 2 n^3, lower triangle; mirrored).
/// The same device as the Kalman filter's covariance step (src/filter). Below n = 32, Eigen's products.
void UpdateWithCongruence(const ConstRef& A, const Eigen::MatrixXd& S, double alpha, double beta, Eigen::MatrixXd* out);

/// n x n buffers of the congruence products, allocated by the caller once for a whole iteration: a fresh
/// 1.3 MB buffer per product (n = 400) is a page-faulting allocation each time, measured at up to a third of
/// the Smith iteration's time (issue 24).
struct CongruenceWork {
  Eigen::MatrixXd L, B;
};

/// UpdateWithCongruence on the lower triangle only: the strictly upper triangle of *out is left as it was
/// for n >= 32 (both triangles are written below). No allocation when *work holds n x n buffers.
void UpdateWithCongruenceLower(const ConstRef& A, const ConstRef& S, double alpha, double beta, CongruenceWork* work,
                               Eigen::MatrixXd* out);

/// lower(*out) += alpha A X A^T for X = L L^T positive definite, X given by its lower triangle: DPOTRF
/// (n^3 / 3), W = A L (DTRMM, n^3), DSYRK (n^3): 2.3 n^3 flops against the 3 n^3 of UpdateWithCongruence.
/// Returns false, with *out unchanged, when n < 32 (Eigen's products are faster there) or X is not
/// numerically positive definite. The strictly upper triangle of *out is left as it was.
bool AddCongruenceOfPdLower(const ConstRef& A, const ConstRef& X, double alpha, CongruenceWork* work,
                            Eigen::MatrixXd* out);

/// |M|_F of the symmetric matrix whose lower triangle M holds.
double LowerFrobeniusNorm(const Eigen::MatrixXd& m);

/// The lower triangle of a product X Y known to be symmetric: lower(*C) = X Y (accumulate = false) or
/// lower(*C) += alpha X Y (accumulate = true), by recursive halving into GEMMs of the off-diagonal blocks and
/// full GEMMs of diagonal blocks of size <= 64: about n^3 + 64 n^2 flops instead of a GEMM's 2 n^3 (measured
/// 1.3-1.9 n^3 of GEMM time at n = 200-400; OpenBLAS 0.3.21 has no DGEMMT). The strictly upper triangle of
/// *C outside the diagonal blocks is left as it was. X, Y: Eigen expressions (a Transpose maps to DGEMM's 'T').
template <typename Lhs, typename Rhs>
void LowerOfSymmetricProduct(const Lhs& X, const Rhs& Y, double alpha, bool accumulate, Eigen::MatrixXd* C,
                             Eigen::Index lo = 0, Eigen::Index hi = -1) {
  if (hi < 0) hi = C->rows();
  const Eigen::Index m = hi - lo;
  if (m <= 64) {
    if (accumulate) {
      C->block(lo, lo, m, m).noalias() += alpha * X.middleRows(lo, m) * Y.middleCols(lo, m);
    } else {
      C->block(lo, lo, m, m).noalias() = alpha * X.middleRows(lo, m) * Y.middleCols(lo, m);
    }
    return;
  }
  const Eigen::Index k = m / 2;
  LowerOfSymmetricProduct(X, Y, alpha, accumulate, C, lo, lo + k);
  if (accumulate) {
    C->block(lo + k, lo, m - k, k).noalias() += alpha * X.middleRows(lo + k, m - k) * Y.middleCols(lo, k);
  } else {
    C->block(lo + k, lo, m - k, k).noalias() = alpha * X.middleRows(lo + k, m - k) * Y.middleCols(lo, k);
  }
  LowerOfSymmetricProduct(X, Y, alpha, accumulate, C, lo + k, hi);
}

/// Buffers handed from one stage of a solve to the next (the DARE: doubling -> refinement -> certificate).
/// A fresh 1.3 MB buffer (n = 400) costs page faults on first touch: measured 4.4 ms on the project's virtual
/// machines (14 us a page, against 0.01 ms to rewrite a warm buffer), more than a GEMM of that size.
class MatrixPool {
 public:
  /// A rows x cols matrix, contents unspecified: a pooled buffer of rows * cols entries if there is one.
  Eigen::MatrixXd Take(Eigen::Index rows, Eigen::Index cols);
  void Give(Eigen::MatrixXd&& m);

 private:
  std::vector<Eigen::MatrixXd> free_;
};

/// Eigenvalues of a general real matrix by LAPACK DGEEV (eigenvalues only). About 4x faster than
/// Eigen::EigenSolver at n = 400 (blocked Hessenberg reduction). Returns false if QR failed.
bool Eigenvalues(const ConstRef& a, Eigen::VectorXcd* eig);

/// max |lambda_i(a)| by Eigenvalues (0 for an empty matrix; NaN if QR failed). No input checks.
double SpectralRadiusUnchecked(const ConstRef& a);

/// Smallest eigenvalue of a symmetric matrix (LAPACK DSYEVR, range 'I', il = iu = 1); NaN on failure.
double MinEigenvalue(const Eigen::MatrixXd& p);

/// CertifyStability on validated input (F, X square of the same size, finite, X exactly symmetric).
StabilityCertificate CertifyUnchecked(const ConstRef& F, const ConstRef& X, double perturbation,
                                      MatrixPool* pool = nullptr);

/// The stabilizing-solution verdict shared by the DARE solvers: the closed loop F (A - K_p C, or
/// E^{-1} (A - K_p C)) and P = sol->P_pred, with `perturbation` the entrywise bound on the rounding of
/// forming F. Unless `exact_eigenvalues`, the Lyapunov certificate decides (its bounds go into sol);
/// DGEEV and DSYEVR run only when it cannot (or gives no bound below 1 - margin). Sets sol's
/// closed_loop_spectral_radius, min_eigenvalue, eigenvalues_exact and lyapunov_certified.
struct StabilizingVerdict {
  bool stable = false;  ///< rho(F) < 1 - stability_margin (proven or from the eigenvalues)
  bool psd = false;     ///< P positive semidefinite within the relative tolerance psd_tolerance
};
StabilizingVerdict JudgeStabilizing(const ConstRef& F, double perturbation, bool exact_eigenvalues,
                                    double stability_margin, double psd_tolerance, DareSolution* sol,
                                    MatrixPool* pool = nullptr);

}  // namespace kfx::detail
