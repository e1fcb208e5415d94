// The generalized discrete Lyapunov equation (SG03AD) and the discrete Sylvester / Stein equation
// (SB04QD); equations and contracts: include/kfx/riccati.hpp.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <complex>
#include <limits>
#include <string>

#include "kfx/error.hpp"
#include "kfx/validation.hpp"
#include "riccati/riccati_internal.hpp"
#include "riccati/slicot_generalized.hpp"

namespace kfx {

using Eigen::MatrixXd;

LyapunovSolution SolveGeneralizedDiscreteLyapunov(const Eigen::Ref<const Eigen::MatrixXd>& A,
                                                  const Eigen::Ref<const Eigen::MatrixXd>& E,
                                                  const Eigen::Ref<const Eigen::MatrixXd>& Q) {
  const auto start = std::chrono::steady_clock::now();
  RequireSquare("A", A);
  RequireFinite("A", A);
  const Eigen::Index n = A.rows();
  RequireShape("E", E, n, n);
  RequireFinite("E", E);
  RequireShape("Q", Q, n, n);
  RequireSymmetric("Q", Q);
  if (n > 0) {
    const double rcond = Eigen::PartialPivLU<MatrixXd>(E).rcond();
    if (!(rcond >= static_cast<double>(n) * std::numeric_limits<double>::epsilon())) {
      throw Error("E: expected a nonsingular matrix, got reciprocal condition number " + FormatNumber(rcond));
    }
  }
  LyapunovSolution sol;
  Summary& s = sol.summary;
  s.computation = "generalized discrete Lyapunov equation";
  s.method = "schur";
  if (n == 0) {
    sol.X.resize(0, 0);
    sol.spectral_radius = 0.0;
    s.termination = Termination::kConverged;
    s.relative_residual = 0.0;
    s.message = "empty (n = 0)";
    return sol;
  }
  detail::Sg03adResult r = detail::SolveGeneralizedLyapunovSg03ad(A, E, Q);
  if (r.eigenvalues.size() > 0) sol.spectral_radius = r.eigenvalues.cwiseAbs().maxCoeff();
  sol.X = std::move(r.X);
  // SG03AD flags a reciprocal pair only when its perturbation kicks in; test the pencil's eigenvalues
  // too (|lambda_i lambda_j - 1| <= 1e3 eps max(1, |lambda_i lambda_j|)).
  bool reciprocal = r.info == 3;
  for (Eigen::Index i = 0; i < r.eigenvalues.size() && !reciprocal; ++i) {
    for (Eigen::Index j = 0; j <= i && !reciprocal; ++j) {
      const std::complex<double> prod = r.eigenvalues(i) * r.eigenvalues(j);
      reciprocal = std::abs(prod - 1.0) <= 1e3 * std::numeric_limits<double>::epsilon() * std::max(1.0, std::abs(prod));
    }
  }
  if (r.info == 2) {
    s.termination = Termination::kFailed;
    s.message = "SG03AD: the QZ algorithm failed";
  } else if (reciprocal) {
    s.termination = Termination::kSingular;
    s.message = "SG03AD: the pencil (A, E) has a reciprocal eigenvalue pair (lambda_i lambda_j = 1)";
  } else if (!(r.scale > 0.0) || !sol.X.allFinite()) {
    s.termination = Termination::kFailed;
    s.message = "SG03AD: the solution overflows (scale " + FormatNumber(r.scale) + ")";
  } else {
    s.termination = Termination::kConverged;
    s.message = "SG03AD";
  }
  if (sol.X.allFinite()) {
    const MatrixXd EXEt = E * sol.X * E.transpose();
    const MatrixXd res = A * sol.X * A.transpose() - EXEt + Q;
    s.relative_residual = res.norm() / std::max(EXEt.norm(), detail::kTiny);
    if (s.ok() && !(s.relative_residual <= 1e-8)) {
      s.termination = Termination::kFailed;
      s.message += "; relative residual " + FormatNumber(s.relative_residual) + " > 1e-8 (nearly singular equation)";
    }
  }
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return sol;
}

SteinSolution SolveDiscreteSylvester(const Eigen::Ref<const Eigen::MatrixXd>& A,
                                     const Eigen::Ref<const Eigen::MatrixXd>& B,
                                     const Eigen::Ref<const Eigen::MatrixXd>& C) {
  const auto start = std::chrono::steady_clock::now();
  RequireSquare("A", A);
  RequireFinite("A", A);
  RequireSquare("B", B);
  RequireFinite("B", B);
  RequireShape("C", C, A.rows(), B.rows());
  RequireFinite("C", C);
  SteinSolution sol;
  Summary& s = sol.summary;
  s.computation = "discrete Sylvester (Stein) equation";
  s.method = "hessenberg-schur";
  if (A.rows() == 0 || B.rows() == 0) {
    sol.X = MatrixXd::Zero(A.rows(), B.rows());
    s.termination = Termination::kConverged;
    s.relative_residual = 0.0;
    s.message = "empty";
    return sol;
  }
  detail::Sb04qdResult r = detail::SolveSteinSb04qd(A, B, C);
  sol.X = std::move(r.X);
  const int m = static_cast<int>(B.rows());
  if (r.info >= 1 && r.info <= m) {
    s.termination = Termination::kFailed;
    s.message = "SB04QD: the QR algorithm failed on B";
  } else if (r.info > m) {
    s.termination = Termination::kSingular;
    s.message = "SB04QD: singular equation (an eigenvalue pair with lambda_i(A) lambda_j(B) ~= 1)";
  } else if (!sol.X.allFinite()) {
    s.termination = Termination::kFailed;
    s.message = "SB04QD: non-finite solution";
  } else {
    s.termination = Termination::kConverged;
    s.message = "SB04QD";
  }
  if (sol.X.allFinite()) {
    const MatrixXd res = A * sol.X * B - sol.X + C;
    s.relative_residual = res.norm() / std::max(sol.X.norm(), detail::kTiny);
  }
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return sol;
}

}  // namespace kfx
