// Subspace estimators of paper 001 (Sec. IV, (4.10)-(4.20)) and the change of basis to block
// upper-triangular form for the least damped modes (ordered real Schur form, LAPACK DGEES + DTRSEN).
#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdint>
#include <limits>
#include <numeric>
#include <utility>
#include <vector>

#include "base/lapack_fortran.hpp"
#include "kfx/error.hpp"
#include "kfx/reduced_order.hpp"
#include "kfx/validation.hpp"
#include "methods/reduced_order/reduced_order_internal.hpp"

namespace kfx {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace {

// A fixed orthogonal n x n matrix, the same on every machine: the Q factor of a matrix of splitmix64
// numbers in (-1, 1).
MatrixXd ReferenceFrame(Index n) {
  std::uint64_t state = 0x2545F4914F6CDD1DULL;
  MatrixXd M(n, n);
  for (Index j = 0; j < n; ++j) {
    for (Index i = 0; i < n; ++i) {
      std::uint64_t z = (state += 0x9E3779B97F4A7C15ULL);
      z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
      z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
      z ^= z >> 31;
      M(i, j) = static_cast<double>(z >> 11) * 0x1.0p-52 - 1.0;
    }
  }
  return Eigen::HouseholderQR<MatrixXd>(M).householderQ();
}

// The orthonormal basis of span(U) (U orthonormal, n x r) closest to the reference columns G (n x r,
// orthonormal): the polar factor of P G, P = U U^T. It depends on span(U) and G only, continuously.
MatrixXd PolarBasis(const MatrixXd& U, const MatrixXd& G) {
  Eigen::JacobiSVD<MatrixXd> svd(U.transpose() * G, Eigen::ComputeFullU | Eigen::ComputeFullV);
  return U * (svd.matrixU() * svd.matrixV().transpose());
}

// Canonical bases of span(U1) and of its orthogonal complement span(U2): the polar factors against the
// first r1 and the last n - r1 columns of one fixed orthogonal frame G. By the CS decomposition
// U1^T G1 and U2^T G2 have the same singular values (but ones), so the two bases are equally well
// determined, and a generic G is in no special position to the subspaces of a symmetric problem.
// The bases used to be taken against coordinate axes picked by a pivoted QR of the projector; on a
// symmetric chain (001 Sec. VI, mirror-image masses) the projector's columns tie in pairs, rounding
// broke the ties, and the basis (so the paper's weight L T^T) changed with the BLAS kernel
// (docs/robustness.md, class 15).
std::pair<MatrixXd, MatrixXd> CanonicalBases(const MatrixXd& U1, const MatrixXd& U2) {
  const MatrixXd G = ReferenceFrame(U1.rows());
  return {PolarBasis(U1, G.leftCols(U1.cols())), PolarBasis(U2, G.rightCols(U2.cols()))};
}

}  // namespace

InvariantSubspaceBasis LeastDampedSubspace(const Eigen::MatrixXd& A, Eigen::Index n_r) {
  RequireSquare("A", A);
  RequireFinite("A", A);
  const int n = static_cast<int>(A.rows());
  if (n_r < 1 || n_r >= n) {
    throw Error("n_r: expected a subspace dimension in 1.." + std::to_string(n - 1) + ", got " + std::to_string(n_r));
  }
  MatrixXd t = A, z(n, n);
  VectorXd wr(n), wi(n);
  int sdim = 0, info = 0, lwork = -1;
  double query = 0.0;
  std::vector<kfx_fortran_logical> bwork(static_cast<size_t>(n));
  dgees_("V", "N", nullptr, &n, t.data(), &n, &sdim, wr.data(), wi.data(), z.data(), &n, &query, &lwork, bwork.data(),
         &info, 1, 1);
  lwork = std::max(static_cast<int>(query), 3 * n);
  std::vector<double> work(static_cast<size_t>(lwork));
  dgees_("V", "N", nullptr, &n, t.data(), &n, &sdim, wr.data(), wi.data(), z.data(), &n, work.data(), &lwork,
         bwork.data(), &info, 1, 1);
  if (info != 0) throw NumericalError("LeastDampedSubspace: DGEES failed (info = " + std::to_string(info) + ")");

  std::vector<int> order(static_cast<size_t>(n));
  std::iota(order.begin(), order.end(), 0);
  auto absval = [&](int i) { return std::hypot(wr(i), wi(i)); };
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return absval(a) > absval(b); });
  const int last = order[static_cast<size_t>(n_r) - 1], next = order[static_cast<size_t>(n_r)];
  const double a = absval(last), b = absval(next);
  if (a - b <= 1e-12 * std::max(1.0, a)) {
    const bool pair = wi(last) != 0.0 && std::abs(wr(last) - wr(next)) <= 1e-12 * std::max(1.0, a) &&
                      std::abs(wi(last) + wi(next)) <= 1e-12 * std::max(1.0, a);
    throw Error(std::string("n_r: the ") + std::to_string(n_r) + " least damped modes are not well defined: " +
                (pair ? "n_r splits a complex conjugate pair" : "|lambda| ties at the boundary"));
  }
  std::vector<kfx_fortran_logical> select(static_cast<size_t>(n), 0);
  for (Index i = 0; i < n_r; ++i) select[static_cast<size_t>(order[static_cast<size_t>(i)])] = 1;
  int m = 0, liwork = 1, iwork = 0;
  double s = 0.0, sep = 0.0;
  int lw = std::max(1, n);
  std::vector<double> work2(static_cast<size_t>(lw));
  dtrsen_("N", "V", select.data(), &n, t.data(), &n, z.data(), &n, wr.data(), wi.data(), &m, &s, &sep, work2.data(),
          &lw, &iwork, &liwork, &info, 1, 1);
  if (info != 0) throw NumericalError("LeastDampedSubspace: DTRSEN failed (info = " + std::to_string(info) + ")");
  KFX_ASSERT(m == n_r);

  InvariantSubspaceBasis out;
  out.n_r = n_r;
  out.T.resize(n, n);
  const auto bases = CanonicalBases(z.leftCols(n_r), z.rightCols(n - n_r));
  out.T.leftCols(n_r) = bases.first;
  out.T.rightCols(n - n_r) = bases.second;
  std::vector<std::complex<double>> sel, oth;
  for (int i = 0; i < n; ++i) (i < n_r ? sel : oth).emplace_back(wr(i), wi(i));
  auto by_abs = [](const std::complex<double>& x, const std::complex<double>& y) { return std::abs(x) > std::abs(y); };
  std::stable_sort(sel.begin(), sel.end(), by_abs);
  std::stable_sort(oth.begin(), oth.end(), by_abs);
  out.eigenvalues = Eigen::Map<Eigen::VectorXcd>(sel.data(), static_cast<Index>(sel.size()));
  out.other_eigenvalues = Eigen::Map<Eigen::VectorXcd>(oth.data(), static_cast<Index>(oth.size()));
  const MatrixXd Vr = out.T.leftCols(n_r);
  out.invariance_residual = (A * Vr - Vr * (Vr.transpose() * A * Vr)).norm() / std::max(A.norm(), 1e-300);
  return out;
}

double TriangularityDefect(const Eigen::MatrixXd& A, const Eigen::MatrixXd& T, Eigen::Index n_r) {
  RequireSquare("A", A);
  RequireShape("T", T, A.rows(), A.rows());
  if (n_r < 1 || n_r > A.rows()) throw Error("n_r: expected 1..n");
  const MatrixXd Ap = T.partialPivLu().solve(A * T);
  return Ap.bottomLeftCorner(A.rows() - n_r, n_r).norm() / std::max(Ap.norm(), 1e-300);
}

namespace {

using detail::SolveRight;

// The model's steps in the coordinates x' = T^{-1} x, and Phi_k from the weights.
class Transformed {
 public:
  Transformed(const Model& model, const MatrixXd& T, Index n_r, const WeightSchedule& L)
      : model_(model), T_(T), n_r_(n_r), L_(L) {
    const Index n = model.state_dim();
    RequireShape("T", T, n, n);
    RequireFinite("T", T);
    if (n_r < 1 || n_r > n) throw Error("n_r: expected a subspace dimension in 1.." + std::to_string(n));
    Eigen::FullPivLU<MatrixXd> lu(T);
    if (!lu.isInvertible()) throw Error("T: expected an invertible change of basis");
    Ti_ = lu.inverse();
  }
  MatrixXd A(int k) const { return Ti_ * model_.step(k)->A * T_; }
  MatrixXd C(int k) const { return model_.step(k)->C * T_; }
  MatrixXd Qn(int k) const {
    MatrixXd q = Ti_ * model_.step(k)->Q * Ti_.transpose();
    Symmetrize(q);
    return q;
  }
  MatrixXd R(int k) const { return model_.step(k)->R; }  // by value: a callback model makes its steps anew
  MatrixXd Phi(int k) const {
    const MatrixXd Lp = L_.at(k) * T_;
    const MatrixXd Lr = Lp.leftCols(n_r_), Ls = Lp.rightCols(Lp.cols() - n_r_);
    const MatrixXd G = Lr.transpose() * Lr;
    Eigen::SelfAdjointEigenSolver<MatrixXd> es(G);
    if (!(es.eigenvalues().minCoeff() > 1e-12 * std::max(es.eigenvalues().maxCoeff(), 1e-300))) {
      throw Error("L: expected L_k V_r of full column rank (Phi needs (L_r^T L_r)^{-1}), step " + std::to_string(k));
    }
    MatrixXd phi(n_r_, Lp.cols());
    phi.leftCols(n_r_).setIdentity();
    phi.rightCols(Lp.cols() - n_r_) = G.llt().solve(Lr.transpose() * Ls);
    return phi;
  }
  MatrixXd Mu(const MatrixXd& phi) const {
    MatrixXd mu = MatrixXd::Zero(phi.cols(), phi.cols());
    mu.topRows(n_r_) = phi;
    return mu;
  }
  double Defect(const MatrixXd& Ap) const {
    return Ap.bottomLeftCorner(Ap.rows() - n_r_, n_r_).norm() / std::max(Ap.norm(), 1e-300);
  }
  double Cost(int k, const MatrixXd& Q) const {
    const MatrixXd LT = L_.at(k) * T_;
    return (LT * Q * LT.transpose()).trace();
  }
  // Prior prediction xi_1 and the second moment of x~_1 = (x_r - xi_1, x_s).
  void Prior(VectorXd* xi1, MatrixXd* Q1) const {
    const StepPtr s1 = model_.step(1);
    const VectorXd mu = Ti_ * (s1->A * model_.m0());
    *xi1 = mu.head(n_r_);
    VectorXd e = mu;
    e.head(n_r_).setZero();
    *Q1 = Ti_ * (s1->A * model_.P0() * s1->A.transpose() + s1->Q) * Ti_.transpose() + e * e.transpose();
    Symmetrize(*Q1);
  }
  Index n_r() const { return n_r_; }

 private:
  const Model& model_;
  const MatrixXd& T_;
  Index n_r_;
  const WeightSchedule& L_;
  MatrixXd Ti_;
};

// N and (I - mu) N (I - mu)^T.
MatrixXd ProjectedLoss(const MatrixXd& N, const MatrixXd& mu) {
  const MatrixXd I_mu = MatrixXd::Identity(mu.rows(), mu.cols()) - mu;
  MatrixXd out = I_mu * N * I_mu.transpose();
  Symmetrize(out);
  return out;
}

}  // namespace

SubspaceOneStep ComputeSubspaceOneStep(const Model& model, const Eigen::MatrixXd& T, Eigen::Index n_r,
                                       const WeightSchedule& L, const ReducedOrderOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const int K = detail::PrepareRun(model, L, options);
  const Transformed tr(model, T, n_r, L);
  SubspaceOneStep out;
  out.meas_dim = model.meas_dim();
  out.Q.resize(static_cast<size_t>(K) + 1);
  out.mu.resize(static_cast<size_t>(K) + 1);
  out.cost = VectorXd::Constant(K + 1, std::numeric_limits<double>::quiet_NaN());
  tr.Prior(&out.xi1, &out.Q[1]);
  out.cost(1) = tr.Cost(1, out.Q[1]);
  out.triangularity_defect = tr.Defect(tr.A(1));
  for (int k = 1; k < K; ++k) {
    const MatrixXd& Q = out.Q[static_cast<size_t>(k)];
    const MatrixXd C = tr.C(k), An = tr.A(k + 1);
    out.triangularity_defect = std::max(out.triangularity_defect, tr.Defect(An));
    const MatrixXd QCt = Q * C.transpose();
    MatrixXd Vh = C * QCt + tr.R(k);
    Symmetrize(Vh);
    const MatrixXd KQ = SolveRight(QCt, Vh, "step " + std::to_string(k));  // Q C^T Vh^{-1}
    const MatrixXd phi = tr.Phi(k + 1);
    const MatrixXd PA = phi * An;
    out.Be.push_back(PA * KQ);
    MatrixXd Ft_KQCr = -KQ * C.leftCols(n_r);  // (I - Q C^T Vh^{-1} C) F^T
    Ft_KQCr.topRows(n_r) += MatrixXd::Identity(n_r, n_r);
    out.Ae.push_back(PA * Ft_KQCr);
    MatrixXd N = An * (KQ * QCt.transpose()) * An.transpose();
    Symmetrize(N);
    const MatrixXd mu = tr.Mu(phi);
    out.mu[static_cast<size_t>(k) + 1] = mu;
    MatrixXd Qn = An * Q * An.transpose() + tr.Qn(k + 1) - N + ProjectedLoss(N, mu);
    Symmetrize(Qn);
    out.Q[static_cast<size_t>(k) + 1] = std::move(Qn);
    out.cost(k + 1) = tr.Cost(k + 1, out.Q[static_cast<size_t>(k) + 1]);
  }
  detail::FinishScheduleSummary("one-step subspace estimator schedule", K, start, nullptr, &out.summary);
  return out;
}

LinearFilter SubspaceOneStepAsLinearFilter(const SubspaceOneStep& s, const Eigen::MatrixXd& T, Eigen::Index n_r) {
  const int K = static_cast<int>(s.Q.size()) - 1;
  if (K < 1 || static_cast<int>(s.Ae.size()) != K - 1) throw Error("s: expected a computed subspace schedule");
  RequireShape("T", T, T.rows(), T.rows());
  if (n_r != s.xi1.size()) throw Error("n_r: expected the schedule's subspace dimension");
  const MatrixXd Vr = T.leftCols(n_r);
  return detail::OneStepFilter(
      s.xi1, s.Ae, s.Be, [&Vr](int) { return Vr; }, s.meas_dim, K);
}

SubspaceTwoStep ComputeSubspaceTwoStep(const Model& model, const Eigen::MatrixXd& T, Eigen::Index n_r,
                                       const WeightSchedule& L, const ReducedOrderOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const int K = detail::PrepareRun(model, L, options);
  const Transformed tr(model, T, n_r, L);
  SubspaceTwoStep out;
  const size_t N = static_cast<size_t>(K) + 1;
  out.Cf.resize(N);
  out.Df.resize(N);
  out.Qf.resize(N);
  out.Qda.resize(N);
  out.mu.resize(N);
  out.cost_da = VectorXd::Constant(K + 1, std::numeric_limits<double>::quiet_NaN());
  out.cost_f = out.cost_da;
  tr.Prior(&out.xi1, &out.Qf[1]);
  out.triangularity_defect = tr.Defect(tr.A(1));
  for (int k = 1; k <= K; ++k) {
    const size_t i = static_cast<size_t>(k);
    const MatrixXd& Qf = out.Qf[i];
    out.cost_f(k) = tr.Cost(k, Qf);
    // Data assimilation (4.16)-(4.18).
    const MatrixXd C = tr.C(k);
    const MatrixXd QCt = Qf * C.transpose();
    MatrixXd Vh = C * QCt + tr.R(k);
    Symmetrize(Vh);
    const MatrixXd KQ = SolveRight(QCt, Vh, "step " + std::to_string(k));
    const MatrixXd phi = tr.Phi(k);
    out.Df[i] = phi * KQ;
    MatrixXd Ft_KQCr = -KQ * C.leftCols(n_r);
    Ft_KQCr.topRows(n_r) += MatrixXd::Identity(n_r, n_r);
    out.Cf[i] = phi * Ft_KQCr;
    MatrixXd S = KQ * QCt.transpose();
    Symmetrize(S);
    out.mu[i] = tr.Mu(phi);
    out.Qda[i] = Qf - S + ProjectedLoss(S, out.mu[i]);
    Symmetrize(out.Qda[i]);
    out.cost_da(k) = tr.Cost(k, out.Qda[i]);
    if (k == K) break;
    // Forecast (4.19)-(4.20).
    const MatrixXd An = tr.A(k + 1);
    out.triangularity_defect = std::max(out.triangularity_defect, tr.Defect(An));
    out.Af.push_back(tr.Phi(k + 1) * An.leftCols(n_r));
    out.Qf[i + 1] = An * out.Qda[i] * An.transpose() + tr.Qn(k + 1);
    Symmetrize(out.Qf[i + 1]);
  }
  detail::FinishScheduleSummary("two-step subspace estimator schedule", K, start, nullptr, &out.summary);
  return out;
}

LinearFilter SubspaceTwoStepAsLinearFilter(const SubspaceTwoStep& s, const Eigen::MatrixXd& T, Eigen::Index n_r,
                                           TwoStepOutput output) {
  const int K = static_cast<int>(s.Qf.size()) - 1;
  if (K < 1 || static_cast<int>(s.Af.size()) != K - 1) throw Error("s: expected a computed subspace schedule");
  if (n_r != s.xi1.size()) throw Error("n_r: expected the schedule's subspace dimension");
  const MatrixXd Vr = T.leftCols(n_r);
  std::vector<MatrixXd> Cf(s.Cf.begin() + 1, s.Cf.end()), Df(s.Df.begin() + 1, s.Df.end());
  return detail::TwoStepFilter(
      s.xi1, Cf, Df, s.Af, [&Vr](int) { return Vr; }, output, K);
}

}  // namespace kfx
