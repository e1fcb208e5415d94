#pragma once
// Private to the riccati layer and the engine (src/core/stationary_performance.cpp): Stein equations on the
// real Schur form, computed once and reused (issue 24). A = U T U^T (LAPACK DGEES), then a recursive
// blocked Bartels-Stewart solve on the quasi-triangular T whose off-diagonal updates are matrix
// products (BLAS level 3), and the back-transformation. Mathematics: docs/riccati.md, "Stein equations
// on the real Schur form".
#include <Eigen/Dense>

#include "riccati/riccati_internal.hpp"

namespace kfx::detail {

/// The real Schur form A = U T U^T of a square matrix (T upper quasi-triangular, standardized 2 x 2
/// blocks for complex pairs; U orthogonal), by LAPACK DGEES.
struct RealSchur {
  Eigen::MatrixXd T;
  Eigen::MatrixXd U;
  Eigen::VectorXcd eigenvalues;  ///< in the order of T's diagonal
  int info = 0;                  ///< DGEES info: 0 success, > 0 the QR algorithm failed
  bool ok() const { return info == 0; }
  double SpectralRadius() const;  ///< max |eigenvalue| (0 for n = 0)
};
RealSchur ComputeRealSchur(const ConstRef& A);

/// Solves Y = T Y S^T + F in place (F holds Y on return) for T (p x p) and S (q x q) upper
/// quasi-triangular (as ComputeRealSchur returns them). Returns false if a diagonal block system was
/// singular to working precision (an eigenvalue pair with lambda_i(T) lambda_j(S) ~= 1); F is then
/// not a solution. Cost about 4 p q (p + q) / 2 flops, in matrix products except for the blocks of
/// size <= 32.
bool SolveQuasiTriangularStein(const ConstRef& T, const ConstRef& S, Eigen::Ref<Eigen::MatrixXd> F);

/// Solves Y = T Y T^T + F in place for symmetric F (both triangles stored; Y exactly symmetric on
/// return), about 3 n^3 flops; false as above.
bool SolveQuasiTriangularLyapunov(const ConstRef& T, Eigen::Ref<Eigen::MatrixXd> F);

/// X = A X A^T + Q (Q symmetric) with A's Schur form a: X = U Y U^T, Y = T Y T^T + U^T Q U
/// (the two congruences 6 n^3 flops, the triangular solve about 3 n^3). False as above.
bool SolveLyapunovBySchur(const RealSchur& a, const ConstRef& Q, Eigen::MatrixXd* X);

/// Y = A Y B^T + F (A n x n, B m x m, F n x m) with the Schur forms a of A and b of B. False as above.
bool SolveSteinBySchur(const RealSchur& a, const RealSchur& b, const ConstRef& F, Eigen::MatrixXd* Y);

}  // namespace kfx::detail
