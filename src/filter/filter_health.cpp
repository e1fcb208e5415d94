// Health of a filter run: the monitor behind FilterRunOptions::monitor_health (symmetry and
// definiteness of each P_{k|k}, the normalized innovation squared; docs/robustness.md) and the
// check that a step's outputs are finite.
#include <algorithm>
#include <cmath>
#include <string>

#include "filter/filter_health_internal.hpp"
#include "kfx/error.hpp"

namespace kfx::detail {

using Eigen::MatrixXd;
using Eigen::VectorXd;

HealthMonitor::HealthMonitor(bool enabled) { h_.monitored = enabled; }

void HealthMonitor::Observe(int k, const Eigen::Ref<const MatrixXd>& P, const Eigen::Ref<const VectorXd>& nu,
                            const Eigen::Ref<const MatrixXd>& S) {
  if (!h_.monitored) return;
  ++h_.steps;
  const double scale = P.cwiseAbs().maxCoeff();
  if (scale > 0.0) h_.max_asymmetry = std::max(h_.max_asymmetry, (P - P.transpose()).cwiseAbs().maxCoeff() / scale);
  const MatrixXd Ps = 0.5 * (P + P.transpose());
  Eigen::SelfAdjointEigenSolver<MatrixXd> eig(Ps, Eigen::EigenvaluesOnly);
  const double lmin = eig.eigenvalues().size() > 0 ? eig.eigenvalues()(0) : 0.0;
  if (lmin < h_.min_eigenvalue) {
    h_.min_eigenvalue = lmin;
    h_.min_eigenvalue_step = k;
  }
  Eigen::LLT<MatrixXd> llt(Ps);
  if (llt.info() != Eigen::Success) {
    if (h_.cholesky_failures == 0) h_.first_cholesky_failure = k;
    ++h_.cholesky_failures;
  }
  if (nu.size() > 0) {
    Eigen::LLT<MatrixXd> s_llt(S);
    if (s_llt.info() == Eigen::Success) {
      h_.nis_sum += s_llt.matrixL().solve(nu).squaredNorm();
      h_.nis_dof += nu.size();
    }
  }
}

FilterHealth HealthMonitor::Finish() const {
  FilterHealth h = h_;
  if (h.monitored && h.nis_dof > 0) {
    h.nis_mean = h.nis_sum / static_cast<double>(h.nis_dof);
    const double half = 2.5758293035489 * std::sqrt(2.0 / static_cast<double>(h.nis_dof));
    h.nis_lower = 1.0 - half;
    h.nis_upper = 1.0 + half;
    h.nis_consistent = h.nis_mean >= h.nis_lower && h.nis_mean <= h.nis_upper;
  }
  return h;
}

void RequireFiniteStep(int k, const Eigen::Ref<const VectorXd>& x, const Eigen::Ref<const MatrixXd>& P,
                       double log_likelihood) {
  if (!x.allFinite()) throw NumericalError("step " + std::to_string(k) + ": estimate x_{k|k} is not finite");
  if (!P.diagonal().allFinite() || !P.allFinite()) {
    throw NumericalError("step " + std::to_string(k) + ": covariance P_{k|k} is not finite");
  }
  if (!std::isfinite(log_likelihood)) {
    throw NumericalError("step " + std::to_string(k) + ": log-likelihood term is not finite");
  }
}

}  // namespace kfx::detail
