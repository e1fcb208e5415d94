#pragma once
// Private: the SLICOT solvers of the generalized equations (issue 22): the descriptor / cross-term
// filter DARE (SG02AD), the generalized discrete Lyapunov equation (SG03AD) and the discrete
// Sylvester (Stein) equation (SB04QD). Separate from slicot.hpp, whose SB02OD / SB03MD serve the
// standard equations.
#include <Eigen/Dense>
#include <string>

#include "riccati/riccati_internal.hpp"

namespace kfx::detail {

/// SLICOT SG02AD (DICO = 'D', JOBL = 'N', SCAL = 'G', ACC = 'R') on the dual control problem
/// (a = A^T, e = E^T, b = C^T, q = Q, r = R, l = S): the stabilizing solution P of
///   E P E^T = A P A^T + Q - (A P C^T + S) (C P C^T + R)^{-1} (A P C^T + S)^T.
struct Sg02adResult {
  int info = 0;         ///< 0 success; 1..7 the failures of SG02AD (message)
  int iwarn = 0;        ///< 1: SG02AD warns that the solution may be inaccurate
  Eigen::MatrixXd P;    ///< n x n as returned (not symmetrized); empty unless info == 0
  double rcond = 0.0;   ///< SG02AD's reciprocal condition estimate of the final linear system
  std::string message;  ///< "SG02AD: rcond = ..." or "SG02AD failed (info i): <reason>"
};
Sg02adResult SolveFilterDareSg02ad(const ConstRef& A, const ConstRef& E, const ConstRef& C, const ConstRef& Q,
                                   const ConstRef& R, const ConstRef& S);

/// SLICOT SG03AD (DICO = 'D', TRANS = 'T') on A X A^T - E X E^T + Q = 0 (Q symmetrized; the result
/// divided by SG03AD's scale and symmetrized). info 3: reciprocal eigenvalue pair of the pencil
/// (A, E) (perturbed values were used).
struct Sg03adResult {
  int info = 0;
  Eigen::MatrixXd X;
  double scale = 1.0;
  Eigen::VectorXcd eigenvalues;  ///< of the pencil A - lambda E (when info is 0 or 3)
};
Sg03adResult SolveGeneralizedLyapunovSg03ad(const ConstRef& A, const ConstRef& E, const ConstRef& Q);

/// SLICOT SB04QD on X + (-A) X B = C, i.e. A X B - X + C = 0 (A n x n, B m x m, C n x m).
struct Sb04qdResult {
  int info = 0;  ///< 0 success; 1..m QR failed on B; > m singular equation
  Eigen::MatrixXd X;
};
Sb04qdResult SolveSteinSb04qd(const ConstRef& A, const ConstRef& B, const ConstRef& C);

}  // namespace kfx::detail
