#pragma once
// Private: the SLICOT solvers kfx calls, in one place for the discrete-time solvers of this layer and
// the continuous-time ones of paper 003 (src/methods/continuous).
#include <Eigen/Dense>
#include <string>

#include "riccati/riccati_internal.hpp"

namespace kfx::detail {

enum class TimeDomain { kDiscrete, kContinuous };

/// SLICOT SB02OD (generalized Schur / QZ method on the extended pencil, P. Van Dooren, SIAM J. Sci.
/// Stat. Comput. 2 (1981) 121-135) with DICO = 'D' or 'C' on the filter's dual control problem
/// (A^T, B = C^T, Q, R, L = S): the stabilizing solution P of the filter DARE
///   P = A P A^T + Q - (A P C^T + S) (C P C^T + R)^{-1} (A P C^T + S)^T      (kDiscrete)
/// or CARE
///   A P + P A^T + Q - (P C^T + S) R^{-1} (C P + S^T) = 0                   (kContinuous),
/// S (n x m) the cross term; nullptr for none (JOBL = 'Z').
struct Sb02odResult {
  int info = 0;         ///< SB02OD's info: 0 success, 1..6 the failures of Sb02odInfoText
  Eigen::MatrixXd P;    ///< n x n as returned (not symmetrized); empty unless info == 0
  double rcond = 0.0;   ///< SB02OD's estimate of the reciprocal condition number of U11
  std::string message;  ///< "SB02OD: rcond(U11) = ..." or "SB02OD failed (info i): <reason>"
};
Sb02odResult SolveFilterRiccatiSb02od(TimeDomain domain, const ConstRef& A, const ConstRef& C, const ConstRef& Q,
                                      const ConstRef& R, const Eigen::MatrixXd* S = nullptr);

/// SLICOT SB03MD (Bartels-Stewart / Barraud on the real Schur form of A) with TRANA = 'T' on
///   A X A^T - X + Q = 0  (kDiscrete, the Stein equation X = A X A^T + Q)   or
///   A X + X A^T + Q = 0  (kContinuous),
/// with Q symmetrized, the result divided by SB03MD's overflow-avoiding scale (<= 1) and symmetrized.
struct Sb03mdResult {
  /// 0 success; 1..n the QR algorithm failed; n + 1: an eigenvalue pair with lambda_i lambda_j ~= 1
  /// (discrete) or lambda_i + lambda_j ~= 0 (continuous), solved with perturbed values.
  int info = 0;
  Eigen::MatrixXd X;             ///< n x n (divided by scale when info == 0 and scale > 0)
  double scale = 1.0;            ///< SB03MD's scale (0: the solution overflows)
  Eigen::VectorXcd eigenvalues;  ///< of A, from the Schur form (when info is 0 or n + 1; else empty)
};
Sb03mdResult SolveLyapunovSb03md(TimeDomain domain, const ConstRef& A, const ConstRef& Q);

}  // namespace kfx::detail
