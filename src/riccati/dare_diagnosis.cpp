// Why the filter DARE has no acceptable solution (DiagnoseDare, dare_internal.hpp).
//
// PBH diagnosis (Hautus tests), run only when no acceptable solution was found:
//   (A, C) detectable        <=> rank [A - lambda I; C]        = n for every |lambda| >= 1,
//   no unreachable mode of (A, Q^{1/2}) on the unit circle
//                            <=> rank [A - lambda I, Q^{1/2}]  = n for every |lambda| = 1.
// These two conditions (with R > 0) are necessary and sufficient for a unique stabilizing PSD
// solution of the filter DARE (e.g. Lancaster & Rodman, Algebraic Riccati Equations, 1995, Ch. 13;
// Chan, Goodwin, Sin, IEEE TAC 29 (1984) 110-118). Rank by SVD with kPbhRankTolerance. Each test is
// one complex SVD: O(k n^3) for k distinct eigenvalues tested (complex-conjugate pairs once), of the
// row- and column-equilibrated matrix; a badly scaled A gives "undecided (badly scaled)" rather
// than a reason that rounding may have made up.
#include <algorithm>
#include <cmath>
#include <complex>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "riccati/dare_internal.hpp"

namespace kfx::detail {

namespace {

using Eigen::Index;
using Eigen::MatrixXd;

/// PBH rank tests: [A - lambda I; C] (or [A - lambda I, Q^{1/2}]) is rank deficient when its
/// smallest singular value is <= kPbhRankTolerance * its largest one. About sqrt(eps): a defective
/// eigenvalue is computed with an error of order sqrt(eps) |A|, which the test must tolerate.
constexpr double kPbhRankTolerance = 1e-7;
/// Eigenvalues with ||lambda| - 1| <= kUnitCircleBand count as on the unit circle, those with
/// |lambda| >= 1 - kUnitCircleBand as not asymptotically stable (PBH tests).
constexpr double kUnitCircleBand = 1e-6;

/// A with max |a_ij| / min nonzero |a_ij| above this is badly scaled: its small entries are below the
/// rounding of its large ones, so a rank decision that depends on them is not trustworthy
/// (docs/robustness.md, class 9).
constexpr double kBadScaling = 1e15;

double ScaleSpread(const ConstRef& A) {
  double hi = 0.0, lo = std::numeric_limits<double>::infinity();
  for (Index j = 0; j < A.cols(); ++j) {
    for (Index i = 0; i < A.rows(); ++i) {
      const double a = std::abs(A(i, j));
      if (a == 0.0) continue;
      hi = std::max(hi, a);
      lo = std::min(lo, a);
    }
  }
  return hi > 0.0 ? hi / lo : 1.0;
}

/// The rank is invariant under nonsingular row and column scaling, the ratio sigma_min / sigma_max
/// is not: with entries of 1e100 in A and 1 in C the unscaled test calls every matrix rank
/// deficient. So the test runs on the equilibrated matrix (rows, then columns, scaled to unit norm
/// by powers of 2, two sweeps; zero rows and columns stay zero).
bool RankDeficient(const Eigen::MatrixXcd& m_in, double* sigma_min, double* sigma_max) {
  Eigen::MatrixXcd m = m_in;
  for (int sweep = 0; sweep < 2; ++sweep) {
    for (Index i = 0; i < m.rows(); ++i) {
      const double r = m.row(i).norm();
      if (r > 0.0 && std::isfinite(r)) m.row(i) *= std::ldexp(1.0, -std::ilogb(r));
    }
    for (Index j = 0; j < m.cols(); ++j) {
      const double c = m.col(j).norm();
      if (c > 0.0 && std::isfinite(c)) m.col(j) *= std::ldexp(1.0, -std::ilogb(c));
    }
  }
  Eigen::BDCSVD<Eigen::MatrixXcd> svd(m);  // singular values only
  const Eigen::VectorXd& sv = svd.singularValues();
  const Index n = std::min(m.rows(), m.cols());
  *sigma_max = sv.size() > 0 ? sv(0) : 0.0;
  *sigma_min = sv.size() > 0 ? sv(n - 1) : 0.0;
  return *sigma_min <= kPbhRankTolerance * std::max(*sigma_max, kTiny);
}

/// When A is badly scaled, a rank defect that is not exact (sigma_min > 0) is no reason to give.
DareDiagnosis Undecided(double spread, const std::string& what) {
  DareDiagnosis d;
  d.found = true;
  d.termination = Termination::kUndecided;
  d.message = "undecided (badly scaled): the entries of A span " + FormatNumber(spread, 3) + " : 1, beyond what " +
              "double precision resolves, so " + what + " cannot be decided; rescale the state";
  return d;
}

std::string ComplexString(std::complex<double> z) {
  std::ostringstream os;
  os.precision(6);
  os << z.real() << (z.imag() < 0 ? " - " : " + ") << std::abs(z.imag()) << "i";
  return os.str();
}

}  // namespace

DareDiagnosis DiagnoseDare(const ConstRef& A, const ConstRef& C, const ConstRef& Q) {
  DareDiagnosis diag;
  const Index n = A.rows(), m = C.rows();
  Eigen::VectorXcd eig;
  if (n == 0 || !Eigenvalues(A, &eig)) return diag;
  // Distinct eigenvalues (clusters within 1e-8 |lambda| merged), upper half plane only.
  std::vector<std::complex<double>> distinct;
  for (Index i = 0; i < n; ++i) {
    const std::complex<double> z = eig(i);
    if (z.imag() < 0) continue;
    bool seen = false;
    for (const auto& w : distinct) seen = seen || std::abs(w - z) <= 1e-8 * std::max(1.0, std::abs(z));
    if (!seen) distinct.push_back(z);
  }
  const Eigen::MatrixXcd Ac = A.cast<std::complex<double>>();
  const double spread = ScaleSpread(A);
  const bool badly_scaled = spread > kBadScaling;
  // Detectability.
  Eigen::MatrixXcd stacked(n + m, n);
  stacked.bottomRows(m) = C.cast<std::complex<double>>();
  for (const auto& z : distinct) {
    if (std::abs(z) < 1.0 - kUnitCircleBand) continue;
    stacked.topRows(n) = Ac;
    stacked.topRows(n).diagonal().array() -= z;
    double smin = 0, smax = 0;
    if (RankDeficient(stacked, &smin, &smax)) {
      if (badly_scaled && smin > 0.0) return Undecided(spread, "the detectability of (A, C)");
      diag.found = true;
      diag.termination = Termination::kNotDetectable;
      diag.message = "(A, C) is not detectable: the mode lambda = " + ComplexString(z) +
                     " (|lambda| = " + FormatNumber(std::abs(z), 6) +
                     ") is unobservable (sigma_min([A - lambda I; C]) = " + FormatNumber(smin) +
                     " <= " + FormatNumber(kPbhRankTolerance) + " * " + FormatNumber(smax) + ")";
      return diag;
    }
  }
  // Unreachable modes of (A, Q^{1/2}) on the unit circle.
  bool any_on_circle = false;
  for (const auto& z : distinct) any_on_circle = any_on_circle || std::abs(std::abs(z) - 1.0) <= kUnitCircleBand;
  if (!any_on_circle) return badly_scaled ? Undecided(spread, "why the DARE failed") : diag;
  Eigen::SelfAdjointEigenSolver<MatrixXd> q_eig(0.5 * (Q + Q.transpose()));
  const Eigen::VectorXd sqrt_vals = q_eig.eigenvalues().cwiseMax(0.0).cwiseSqrt();
  const MatrixXd q_half = q_eig.eigenvectors() * sqrt_vals.asDiagonal() * q_eig.eigenvectors().transpose();
  Eigen::MatrixXcd side(n, 2 * n);
  side.rightCols(n) = q_half.cast<std::complex<double>>();
  for (const auto& z : distinct) {
    if (std::abs(std::abs(z) - 1.0) > kUnitCircleBand) continue;
    side.leftCols(n) = Ac;
    side.leftCols(n).diagonal().array() -= z;
    double smin = 0, smax = 0;
    if (RankDeficient(side, &smin, &smax)) {
      if (badly_scaled && smin > 0.0) return Undecided(spread, "the stabilizability of (A, Q^{1/2})");
      diag.found = true;
      diag.termination = Termination::kNotStabilizable;
      diag.message = "(A, Q^{1/2}) is not stabilizable on the unit circle: the mode lambda = " + ComplexString(z) +
                     " (|lambda| = " + FormatNumber(std::abs(z), 6) +
                     ") receives no process noise (sigma_min([A - lambda I, Q^{1/2}]) = " + FormatNumber(smin) +
                     " <= " + FormatNumber(kPbhRankTolerance) + " * " + FormatNumber(smax) + ")";
      return diag;
    }
  }
  return badly_scaled ? Undecided(spread, "why the DARE failed") : diag;
}

}  // namespace kfx::detail
