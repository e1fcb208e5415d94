// The filter DARE by structure-preserving doubling (SolveDareByDoubling, dare_internal.hpp), run on the dual
// control DARE X = Ã^T X (I + G X)^{-1} Ã + Q with Ã = A^T, G = C^T R^{-1} C (dare.cpp):
//
// E.K.-W. Chu, H.-Y. Fan, W.-W. Lin,
// "A structure-preserving doubling algorithm for continuous-time algebraic Riccati equations",
// Linear Algebra Appl. 396 (2005) 55-80, and its discrete-time form for
// X = Ã^T X (I + G X)^{-1} Ã + H (E.K.-W. Chu, H.-Y. Fan, W.-W. Lin, C.-S. Wang,
// "Structure-preserving algorithms for periodic discrete-time algebraic Riccati equations",
// Int. J. Control 77 (2004); convergence: W.-W. Lin, S.-F. Xu, SIAM J. Matrix Anal. Appl. 28
// (2006) 26-39):
//     A_0 = Ã = A^T,  G_0 = C^T R^{-1} C,  H_0 = Q,   W_k = I + G_k H_k,
//     A_{k+1} = A_k W_k^{-1} A_k,
//     G_{k+1} = G_k + A_k W_k^{-1} G_k A_k^T,
//     H_{k+1} = H_k + A_k^T H_k W_k^{-1} A_k,
// H_k -> P quadratically when (A, C) is detectable and (A, Q^{1/2}) has no unreachable mode on
// the unit circle (A_k = O(rho(A - K_p C)^{2^k})); linearly in the critical case. H_k is the
// Riccati iterate after 2^k steps started at P = 0, so it converges to the smallest PSD
// solution; that is the stabilizing one unless (A, Q^{1/2}) has unreachable modes outside the
// unit circle (e.g. Q = 0 with unstable A), which is why kAuto falls back to the Schur method.
#include <cmath>
#include <limits>
#include <string>
#include <vector>

#include "base/lapack_fortran.hpp"
#include "riccati/dare_internal.hpp"

namespace kfx::detail {

namespace {

using Eigen::Index;
using Eigen::MatrixXd;

/// Doubling is declared divergent when |H_k|_F or |G_k|_F exceeds this factor times its start.
constexpr double kDivergenceGrowth = 1e100;

/// True when the relative changes e_{k-1} = prev, e_k = last of two consecutive steps show quadratic
/// convergence and predict the next change below a hundredth of the tolerance: e_{k+1} ~ c e_k^2 with
/// c = e_k / e_{k-1}^2, i.e. e_{k+1} ~ e_k^3 / e_{k-1}^2. Then H_{k+1} is the limit to within the tolerance
/// and the step that would only confirm it (G_{k+1}, A_{k+1} and step k + 1: 14.7 n^3 flops, 18% of a
/// 6-step solve) is skipped. Asked only of a change already <= 1e-6 that is superlinear (e_k <= e_{k-1}^1.5):
/// a linear (critical-case) convergence never qualifies. Measured on the benchmark systems (rho(A) = 0.95,
/// n = 200, 400): e = 8.6e-5, 1.4e-9 predict 3.5e-19, and step 6 then measured 2.1e-19.
bool PredictsConvergence(double prev, double last, double tolerance) {
  if (!(prev > 0.0) || !std::isfinite(prev) || !(last > 0.0) || last > 1e-6 || last > std::pow(prev, 1.5)) {
    return false;
  }
  const double ratio = last / prev;
  return ratio * ratio * last <= 1e-2 * tolerance;
}

}  // namespace

// Structure-preserving doubling (see the file comment). Per step, with one LU of W_k:
//   Y1 = W_k^{-1} A_k                                   (DGETRF 2/3 n^3, DGETRS 2 n^3)
//   D   = A_k^T (H_k Y1)         = H_{k+1} - H_k        (1 GEMM; D's lower triangle only, ~1 n^3)
// and, unless H_{k+1} passed the stopping test (then they are not needed),
//   Y2 = W_k^{-1} G_k                                   (DGETRS 2 n^3)
//   G  += A_k Y2 A_k^T                                  (DTRMM + DSYR2K, 3 n^3; UpdateWithCongruence)
//   A_{k+1} = A_k Y1                                    (1 GEMM)
// plus W_k = I + G_k H_k (1 GEMM): about 14.7 n^3 flops per step (7.7 n^3 for the last), all in
// BLAS 3, with every n x n buffer allocated once (a fresh one costs page faults: 4 ms per 1.3 MB on the
// project's virtual machines, more than a GEMM at n = 400). H_k W_k^{-1} and
// W_k^{-1} G_k are symmetric in exact arithmetic, H and G are re-symmetrized after each step.
// The increment D is formed explicitly, so the stopping test |D|_F <= tol |H_{k+1}|_F has no
// cancellation floor.
DareCandidate SolveDareByDoubling(const ConstRef& A, const ConstRef& C, const ConstRef& Q, const ConstRef& R,
                                  const DareOptions& options, MatrixPool* pool) {
  DareCandidate out;
  out.method = DareMethod::kDoubling;
  const Index n = A.rows();
  const int nf = FortranInt(n);

  // G_0 = C^T R^{-1} C = Z^T Z with Z = L^{-1} C, R = L L^T (validated PD, so LLT succeeds).
  Eigen::LLT<MatrixXd> r_llt(R);
  if (r_llt.info() != Eigen::Success) {
    out.message = "doubling: Cholesky factorization of R failed";
    return out;
  }
  MatrixXd Z = C;
  r_llt.matrixL().solveInPlace(Z);
  // The n x n buffers, from the pool and back to it on every return (H goes out as the result).
  struct Buffers {
    MatrixPool* pool;
    MatrixXd G, H, Ak, W, Y1, Y2, T, D;
    CongruenceWork work;
    ~Buffers() {
      for (MatrixXd* m : {&G, &H, &Ak, &W, &Y1, &Y2, &T, &D, &work.L, &work.B}) pool->Give(std::move(*m));
    }
  } b{pool,
      pool->Take(n, n),
      pool->Take(n, n),
      pool->Take(n, n),
      pool->Take(n, n),
      pool->Take(n, n),
      pool->Take(n, n),
      pool->Take(n, n),
      pool->Take(n, n),
      {pool->Take(n, n), pool->Take(n, n)}};
  MatrixXd &G = b.G, &H = b.H, &Ak = b.Ak, &W = b.W, &Y1 = b.Y1, &Y2 = b.Y2, &T = b.T, &D = b.D;
  CongruenceWork& work = b.work;
  G.noalias() = Z.transpose() * Z;
  H = Q;
  SymmetrizeInPlace(H);
  Ak = A.transpose();

  std::vector<int> ipiv(static_cast<std::size_t>(std::max<Index>(n, 1)));
  const double h_start = std::max(H.norm(), kTiny);
  const double g_start = std::max(G.norm(), kTiny);

  double last_change = std::numeric_limits<double>::infinity(), prev_change = 0.0;
  for (int k = 1; k <= options.max_iterations; ++k) {
    W.noalias() = G * H;
    W.diagonal().array() += 1.0;
    int info = 0;
    dgetrf_(&nf, &nf, W.data(), &nf, ipiv.data(), &info);
    KFX_ASSERT(info >= 0);
    if (info > 0) {
      out.iterations = k;
      out.P = H;
      out.message = "doubling: W = I + G_k H_k is singular at step " + std::to_string(k) + " (DGETRF info " +
                    std::to_string(info) + ")";
      return out;
    }
    Y1 = Ak;  // W_k^{-1} A_k
    dgetrs_("N", &nf, &nf, W.data(), &nf, ipiv.data(), Y1.data(), &nf, &info, 1);
    KFX_ASSERT(info == 0);
    T.noalias() = H * Y1;
    LowerOfSymmetricProduct(Ak.transpose(), T, 1.0, false, &D);  // lower(D) = A_k^T T (symmetric)
    H.triangularView<Eigen::Lower>() += D;
    H.triangularView<Eigen::StrictlyUpper>() = H.transpose();
    const double change = LowerFrobeniusNorm(D);
    const double h_norm = H.norm();
    out.iterations = k;
    if (!std::isfinite(change) || !std::isfinite(h_norm) || h_norm > kDivergenceGrowth * h_start) {
      out.message = "doubling diverged at step " + std::to_string(k) + " (|H_k|_F = " + FormatNumber(h_norm) + ")";
      out.P.resize(0, 0);  // nothing usable
      return out;
    }
    prev_change = last_change;
    last_change = change / std::max(h_norm, kTiny);
    if (options.progress) options.progress(k, options.max_iterations);
    const bool predicted = PredictsConvergence(prev_change, last_change, options.tolerance);
    if (change <= options.tolerance * h_norm || predicted) {  // converged: G_{k+1}, A_{k+1} are not needed
      out.P = std::move(H);
      out.termination = Termination::kConverged;
      out.message = "doubling converged in " + std::to_string(k) + " steps (relative change " +
                    FormatNumber(last_change) +
                    (predicted ? ", the next one predicted below the tolerance by quadratic convergence)" : ")");
      return out;
    }
    Y2 = G;  // W_k^{-1} G_k (symmetric in exact arithmetic), with the same LU factors
    dgetrs_("N", &nf, &nf, W.data(), &nf, ipiv.data(), Y2.data(), &nf, &info, 1);
    KFX_ASSERT(info == 0);
    UpdateWithCongruenceLower(Ak, Y2, 1.0, 1.0, &work, &G);  // G += A_k Y2 A_k^T (exactly symmetric)
    G.triangularView<Eigen::StrictlyUpper>() = G.transpose();
    T.noalias() = Ak * Y1;
    Ak.swap(T);
    const double g_norm = G.norm();
    if (!std::isfinite(g_norm) || g_norm > kDivergenceGrowth * g_start) {
      out.message = "doubling diverged at step " + std::to_string(k) + " (|G_k|_F = " + FormatNumber(g_norm) + ")";
      out.P.resize(0, 0);
      return out;
    }
  }
  out.P = std::move(H);
  out.termination = Termination::kNotConverged;
  out.message = "doubling: no convergence in " + std::to_string(options.max_iterations) +
                " steps (last relative change " + FormatNumber(last_change) + " > tolerance " +
                FormatNumber(options.tolerance) + ")";
  return out;
}

}  // namespace kfx::detail
