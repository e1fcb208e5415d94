// The other one-step covariance updates of 004 beside the O(n r^2) block-diagonal step: its naive
// dense form, eqs. (3)-(6) (the reference the fast form is tested against), the banded filter's step
// and the full Kalman filter's step on the stacked system.
#include <utility>

#include "kfx/block_diagonal.hpp"
#include "kfx/error.hpp"
#include "kfx/simulation.hpp"
#include "kfx/validation.hpp"
#include "methods/block_diagonal/block_diagonal_shared.hpp"

namespace kfx {

using detail::BlockOf;
using detail::RequirePackedCovariance;
using detail::RequireStepShapes;
using detail::SubsystemKalmanSteps;
using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

// ---- The naive block-diagonal step, eqs. (3)-(6) ------------------------------------------------------

DenseGainCovarianceStep NaiveBlockDiagonalCovarianceUpdate(const CoupledStep& s, const MatrixXd& Pp) {
  RequireStepShapes(s, "");
  const Index c = s.c();
  RequirePackedCovariance("P_prev", Pp, c, s.n());
  const ModelStep dense = ToDenseStep(s);
  // (3) P~_{k|k-1} = F P~ F^T + V + G U G^T
  MatrixXd P = dense.A * BlockDiagonalToDense(Pp, c) * dense.A.transpose() + dense.Q;
  Symmetrize(P);
  // (4) S = H P H^T + R, (5) K = P H^T S^{-1}
  const MatrixXd PHt = P * dense.C.transpose();
  const MatrixXd S = dense.C * PHt + dense.R;
  Eigen::LLT<MatrixXd> llt(S);
  if (llt.info() != Eigen::Success) throw NumericalError("S: H P H^T + R is not positive definite");
  DenseGainCovarianceStep out;
  out.K = llt.solve(PHt.transpose()).transpose();
  // (6) P~_{k|k} = D{(I - K H) P~_{k|k-1}}
  MatrixXd Pf = P - out.K * dense.C * P;
  Symmetrize(Pf);
  out.P_filt = DiagonalBlocks(Pf, c);
  return out;
}

// ---- The banded step ---------------------------------------------------------------------------------

MatrixXd BandedProcessNoise(const CoupledStep& s) {
  RequireStepShapes(s, "");
  const Index n = s.n(), c = s.c(), r = s.r();
  MatrixXd Q = s.V;
  if (r == 0) return Q;
  const MatrixXd GS = s.G * PsdFactor(s.U);  // (n c) x k
  for (Index i = 0; i < n; ++i) {
    BlockOf(Q, i, c).noalias() += GS.middleRows(i * c, c) * GS.middleRows(i * c, c).transpose();
  }
  return Q;
}

BandedCovarianceStep BandedCovarianceUpdate(const CoupledStep& s, const MatrixXd& Pp) {
  return BandedCovarianceUpdate(s, Pp, BandedProcessNoise(s));
}

BandedCovarianceStep BandedCovarianceUpdate(const CoupledStep& s, const MatrixXd& Pp, const MatrixXd& Qb) {
  RequireStepShapes(s, "");
  const Index n = s.n(), c = s.c(), d = s.d();
  RequirePackedCovariance("P_prev", Pp, c, n);
  RequirePackedCovariance("Q_blocks", Qb, c, n);
  BandedCovarianceStep out;
  out.P_filt.resize(c, n * c);
  out.K.resize(c, n * d);
  SubsystemKalmanSteps(s, Pp, Qb, 0, n, nullptr, out.K, out.P_filt);
  return out;
}

// ---- The full Kalman filter on the stacked system ----------------------------------------------------

VectorXd FullCovarianceStep::Apply(const VectorXd& innovation) const {
  RequireVector("innovation", innovation, HP.rows());
  return HP.transpose() * S.solve(innovation);
}

MatrixXd FullCovarianceStep::ToDense() const { return S.solve(HP).transpose(); }

FullCovarianceStep FullCovarianceUpdate(const CoupledStep& s, const MatrixXd& Pprev) {
  RequireStepShapes(s, "");
  const Index n = s.n(), c = s.c(), d = s.d(), N = n * c;
  RequireShape("P_prev", Pprev, N, N);
  FullCovarianceStep out;
  // Predict: P = F P F^T + blockdiag(V) + G U G^T with block-diagonal F (left, then right).
  MatrixXd P(N, N);
  for (Index i = 0; i < n; ++i) P.middleRows(i * c, c).noalias() = BlockOf(s.F, i, c) * Pprev.middleRows(i * c, c);
  MatrixXd P2(N, N);
  for (Index i = 0; i < n; ++i)
    P2.middleCols(i * c, c).noalias() = P.middleCols(i * c, c) * BlockOf(s.F, i, c).transpose();
  P = std::move(P2);
  for (Index i = 0; i < n; ++i) P.block(i * c, i * c, c, c) += BlockOf(s.V, i, c);
  if (s.r() > 0) {
    const MatrixXd GS = s.G * PsdFactor(s.U);
    P.selfadjointView<Eigen::Lower>().rankUpdate(GS);
  }
  P.triangularView<Eigen::StrictlyUpper>() = P.transpose();
  // Update: HP = blockdiag(H) P, S = HP H^T + blockdiag(R), P_filt = P - HP^T S^{-1} HP.
  out.HP.resize(n * d, N);
  for (Index i = 0; i < n; ++i) out.HP.middleRows(i * d, d).noalias() = BlockOf(s.H, i, c) * P.middleRows(i * c, c);
  MatrixXd S(n * d, n * d);
  for (Index j = 0; j < n; ++j)
    S.middleCols(j * d, d).noalias() = out.HP.middleCols(j * c, c) * BlockOf(s.H, j, c).transpose();
  for (Index i = 0; i < n; ++i) S.block(i * d, i * d, d, d) += BlockOf(s.R, i, d);
  S = 0.5 * (S + S.transpose()).eval();
  out.S.compute(S);
  if (out.S.info() != Eigen::Success) throw NumericalError("S: H P H^T + R is not positive definite");
  MatrixXd W = out.S.matrixL().solve(out.HP);  // L^{-1} H P
  P.selfadjointView<Eigen::Lower>().rankUpdate(W.transpose(), -1.0);
  P.triangularView<Eigen::StrictlyUpper>() = P.transpose();
  out.P_filt = std::move(P);
  return out;
}

}  // namespace kfx
