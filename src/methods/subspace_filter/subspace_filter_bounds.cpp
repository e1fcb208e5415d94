// The error bounds of Sec. 4 of paper 000: Theorem 4.1 ((25), (27), Lemma A.1's L and L_0),
// Theorem 4.2 and Remark 4.3 (subspace_filter.hpp). Corrections: docs/papers/000.md.
#include <chrono>
#include <cmath>
#include <limits>

#include "kfx/error.hpp"
#include "kfx/subspace_filter.hpp"
#include "kfx/validation.hpp"

namespace kfx {

namespace {

using Eigen::MatrixXd;

double Norm2(const MatrixXd& X) {
  if (X.size() == 0) return 0.0;
  const MatrixXd G = X.rows() >= X.cols() ? MatrixXd(X.transpose() * X) : MatrixXd(X * X.transpose());
  Eigen::SelfAdjointEigenSolver<MatrixXd> es(G, Eigen::EigenvaluesOnly);
  return std::sqrt(std::max(0.0, es.eigenvalues().maxCoeff()));
}

// L of Lemma A.1 (iii): sup tr(L^{-1} X) / tr X over X >= 0 = lambda_max(Y), Y = Phi^T Y Phi + I
// (the adjoint of (29) applied to I); +inf when the equation has no solution (Phi not stable).
double TraceBoundL(const MatrixXd& Phi) {
  const LyapunovSolution sol = SolveDiscreteLyapunov(Phi.transpose(), MatrixXd::Identity(Phi.rows(), Phi.cols()));
  if (!sol.summary.ok()) return std::numeric_limits<double>::infinity();
  const MatrixXd& Y = sol.X;
  Eigen::SelfAdjointEigenSolver<MatrixXd> es(0.5 * (Y + Y.transpose()), Eigen::EigenvaluesOnly);
  return es.eigenvalues().maxCoeff();
}

// sum_j |Phi^j|^2 and sum_j |Phi^{2j}| (Lemma A.1 as printed), each summed up to an even J with
// |Phi^J| <= 0.1 and the tail bounded by submultiplicativity: j = q J + r gives |Phi^j| <= |Phi^J|^q |Phi^r|.
void SeriesL0(const MatrixXd& Phi, double* squares, double* printed) {
  const Eigen::Index n = Phi.rows();
  MatrixXd Pw = MatrixXd::Identity(n, n);
  double s2 = 0.0, se = 0.0;
  const int kMax = 200000;
  for (int j = 0; j < kMax; ++j) {
    const double nj = j == 0 ? 1.0 : Norm2(Pw);
    if (j > 0 && j % 2 == 0 && nj <= 0.1) {
      *squares = s2 / (1.0 - nj * nj);
      *printed = se / (1.0 - nj);
      return;
    }
    s2 += nj * nj;
    if (j % 2 == 0) se += nj;
    Pw = (Phi * Pw).eval();
  }
  *squares = std::numeric_limits<double>::infinity();
  *printed = std::numeric_limits<double>::infinity();
}

}  // namespace

DiscretizationBounds ComputeDiscretizationBounds(const ModelStep& truth, const Eigen::MatrixXd& S,
                                                 const Subspace& subspace, const SubspaceFilterSchedule& schedule) {
  const auto t0 = std::chrono::steady_clock::now();
  const Eigen::Index N = truth.state_dim(), m = truth.meas_dim();
  ValidateStep(truth, N, m, "truth: ");
  RequireShape("S", S, N, N);
  ValidateSubspace(subspace, N);
  if (schedule.K.rows() != N || schedule.Q.rows() != N || schedule.P_final.rows() != N) {
    throw Error("schedule: expected a schedule computed for this model");
  }
  // W-orthonormal coordinates x' = L^T x (W = L L^T): operators T -> L^T T L^{-T}, covariances
  // Sigma -> L^T Sigma L, C -> C L^{-T}, gains K -> L^T K; then * is ^T and tr_X is tr.
  MatrixXd Lt = MatrixXd::Identity(N, N);
  if (subspace.gram.size() > 0) {
    Eigen::LLT<MatrixXd> llt(subspace.gram);
    Lt = llt.matrixU();  // L^T
  }
  auto op = [&](const MatrixXd& T) -> MatrixXd {  // L^T T L^{-T}
    const MatrixXd LtT = Lt * T;
    return Lt.transpose().triangularView<Eigen::Lower>().solve(LtT.transpose()).transpose();
  };
  auto cov = [&](const MatrixXd& X) -> MatrixXd {
    MatrixXd Y = Lt * X * Lt.transpose();
    Symmetrize(Y);
    return Y;
  };
  const MatrixXd A = op(truth.A);
  const MatrixXd C = Lt.transpose().triangularView<Eigen::Lower>().solve(truth.C.transpose()).transpose();
  const MatrixXd Qn = cov(truth.Q);
  const MatrixXd& R = truth.R;
  const MatrixXd Pi = Lt.transpose().triangularView<Eigen::Lower>().solve(subspace.projection.transpose()).transpose();
  const MatrixXd I = MatrixXd::Identity(N, N);
  const MatrixXd IPs = I - Pi.transpose() * Pi;
  MatrixXd M = IPs * cov(S) * IPs.transpose();
  Symmetrize(M);
  const MatrixXd K_inf = Lt * schedule.K;

  DiscretizationBounds b;
  b.summary.computation = "discretization bounds";
  b.summary.method = "Theorems 4.1, 4.2, Remark 4.3";
  const auto finish = [&b, t0]() {
    b.summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return b;
  };
  b.trace_M = M.trace();
  {
    // M_inf (21) from the converged quantities: (I - Q Pi) (A Q S~ Q^T A^T + K (C P~ C^T + R) K^T) (I - Q Pi)^T.
    const MatrixXd AQ = truth.A * schedule.Q;
    MatrixXd Sinn = truth.R + truth.C * schedule.P_pred * truth.C.transpose();
    MatrixXd X = AQ * schedule.S_tilde * AQ.transpose() + schedule.K * Sinn * schedule.K.transpose();
    const MatrixXd IQPi = MatrixXd::Identity(N, N) - schedule.Q * subspace.projection;
    b.trace_M_inf = cov(IQPi * X * IQPi.transpose()).trace();
  }

  // Full filter (23) with W^(F) = Q and the perturbed one with W^(b) = Q + A M A^T.
  const DareSolution full = SolveFilterDare(A, C, Qn, R);
  if (!full.summary.ok()) {
    AdoptOutcome(full.summary, &b.summary);
    b.summary.message = "full-state " + b.summary.message;
    return finish();
  }
  MatrixXd Qb = Qn + A * M * A.transpose();
  Symmetrize(Qb);
  const DareSolution pert = SolveFilterDare(A, C, Qb, R);
  if (!pert.summary.ok()) {
    AdoptOutcome(pert.summary, &b.summary);
    b.summary.message = "(23) with W^(b): " + b.summary.message;
    return finish();
  }
  b.P_full = full.P_filt;
  b.P_b = pert.P_filt;
  b.trace_delta_P = (pert.P_filt - full.P_filt).trace();

  const MatrixXd& KF = full.filter_gain;
  const MatrixXd CA = C * A;
  const MatrixXd PhiF = A - KF * CA;
  const MatrixXd PhiInf = A - K_inf * CA;
  b.rho_full = SpectralRadius(PhiF);
  b.rho_reduced = SpectralRadius(PhiInf);
  {
    const MatrixXd AQ = truth.A * schedule.Q;
    const MatrixXd PiK = subspace.projection * schedule.K;
    b.rho_reduced_filter = SpectralRadius(subspace.projection * AQ - PiK * (truth.C * AQ));
  }
  b.L = TraceBoundL(PhiF);
  b.L_tilde = TraceBoundL(PhiInf);
  SeriesL0(PhiF, &b.L0, &b.L0_printed);

  const double nA = Norm2(A), nC = Norm2(C), nCA = Norm2(CA), nPhiF = Norm2(PhiF), nKFC = Norm2(KF * C);
  const MatrixXd Sinv = full.innovation_cov.inverse();
  const double nSinv = Norm2(Sinv), trSinv = Sinv.trace(), nPtF = Norm2(full.P_pred);
  b.c_hat1 = (1.0 + nPtF * nC * nC * nSinv) * nC * nA * nA * nSinv;
  b.c_hat2 = std::pow(nA, 4) * std::pow(nC, 3) * nSinv * nSinv;
  b.a = b.L * nPhiF * nPhiF;
  b.b = b.L * nKFC * nKFC * std::pow(nA, 4) * nC * nC * trSinv;
  b.c1 = 2 * b.L0 * nPhiF * nCA * b.c_hat1;
  b.c2 = 2 * b.L0 * nPhiF * nCA * b.c_hat2 + b.L0 * nCA * nCA * b.c_hat1 * b.c_hat1;
  b.c3 = 2 * b.L0 * nCA * nCA * b.c_hat1 * b.c_hat2;
  b.c4 = b.L0 * nCA * nCA * b.c_hat2 * b.c_hat2;
  const double t = b.trace_M;
  b.denominator = 1.0 - (b.c1 * t + b.c2 * t * t + b.c3 * t * t * t + b.c4 * t * t * t * t);
  b.trace_delta_P_bound =
      b.denominator > 0 ? (b.a * t + b.b * t * t) / b.denominator : std::numeric_limits<double>::infinity();
  b.theorem41 = t + b.trace_delta_P_bound;
  b.theorem41_exact_dP = t + b.trace_delta_P;
  // Theorem 4.2 in terms of tr M (C_1 |I - Pi_s|^2 -> (1 + L~ |Phi_F|^2) tr M, C_2 |I - Pi_s|^4 -> the tr M^2 term).
  const double e2 = nKFC * nKFC * std::pow(nA, 4) * nC * nC * trSinv;
  b.theorem42 = t + b.L_tilde * (nPhiF * nPhiF * t + e2 * t * t);
  // Remark 4.3: no K^(F), P~^(F): |Phi_F|^2 <= 2 |Phi_inf|^2 + 2 |CA|^2 |dK|_HS^2 with (26) evaluated with
  // |P~^(F)| <= |P~^(a)|, |(C P~ C^T + R)^{-1}| <= 1 / lambda_min(R), tr(...)^{-1} <= tr R^{-1};
  // |K^(F) C| <= |P~^(a)| |C|^2 / lambda_min(R).
  {
    Eigen::SelfAdjointEigenSolver<MatrixXd> es(R, Eigen::EigenvaluesOnly);
    const double rmin = es.eigenvalues().minCoeff();
    const double nPa = Norm2(cov(schedule.P_pred));
    const double ch1 = (1.0 + nPa * nC * nC / rmin) * nC * nA * nA / rmin;
    const double ch2 = std::pow(nA, 4) * std::pow(nC, 3) / (rmin * rmin);
    const double dK = (ch1 + ch2 * t) * t;
    const double nPhiInf = Norm2(PhiInf);
    const double phi2 = 2 * nPhiInf * nPhiInf + 2 * nCA * nCA * dK * dK;
    const double kfc = nPa * nC * nC / rmin;
    const double e2r = kfc * kfc * std::pow(nA, 4) * nC * nC * R.inverse().trace();
    b.remark43 = t + b.L_tilde * (phi2 * t + e2r * t * t);
  }
  b.actual = cov(schedule.P_final).trace() - full.P_filt.trace();
  b.summary.termination = Termination::kConverged;
  return finish();
}

}  // namespace kfx
