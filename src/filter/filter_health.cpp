// Health of a filter run: the monitor behind FilterRunOptions::monitor_health (symmetry and
// definiteness of each P_{k|k}, the normalized innovation squared; docs/robustness.md) and the
// check that a step's outputs are finite.
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <string>

#include "filter/filter_health_internal.hpp"
#include "kfx/error.hpp"
#include "kfx/kalman_filter.hpp"

namespace kfx::detail {

using Eigen::MatrixXd;
using Eigen::VectorXd;

HealthMonitor::HealthMonitor(bool enabled, bool eigenvalues) : eigenvalues_(eigenvalues) { h_.monitored = enabled; }

void HealthMonitor::Observe(int k, const Eigen::Ref<const MatrixXd>& P, const Eigen::Ref<const VectorXd>& nu,
                            const Eigen::Ref<const MatrixXd>& S) {
  if (!h_.monitored) return;
  ++h_.steps;
  const double scale = P.cwiseAbs().maxCoeff();
  if (scale > 0.0) h_.max_asymmetry = std::max(h_.max_asymmetry, (P - P.transpose()).cwiseAbs().maxCoeff() / scale);
  const MatrixXd Ps = 0.5 * (P + P.transpose());
  Eigen::LLT<MatrixXd> llt(Ps);
  const bool factored = llt.info() == Eigen::Success;
  if (!factored) {
    if (h_.cholesky_failures == 0) h_.first_cholesky_failure = k;
    ++h_.cholesky_failures;
  }
  if (eigenvalues_ || !factored) {
    Eigen::SelfAdjointEigenSolver<MatrixXd> eig(Ps, Eigen::EigenvaluesOnly);
    const double lmin = eig.eigenvalues().size() > 0 ? eig.eigenvalues()(0) : 0.0;
    if (lmin < h_.min_eigenvalue) {
      h_.min_eigenvalue = lmin;
      h_.min_eigenvalue_step = k;
    }
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

}  // namespace kfx::detail

namespace kfx {

std::string HealthWarning(const FilterHealth& h, const KalmanFilterOptions& filter) {
  if (!h.monitored || h.healthy()) return "";
  std::ostringstream os;
  os << std::setprecision(3);
  if (h.cholesky_failures > 0) {
    os << "P_{k|k} is not positive definite at " << h.cholesky_failures << " of " << h.steps << " steps (first at step "
       << h.first_cholesky_failure << ", smallest eigenvalue " << h.min_eigenvalue << " at step "
       << h.min_eigenvalue_step << "): the covariances are wrong; ";
    if (filter.form == FilterForm::kConventional || filter.form == FilterForm::kInformation) {
      os << "use the UD or the square-root form (CLI --form ud or --form sqrt; KalmanFilterOptions::form "
            "kUD / kSquareRoot), which keep P positive definite (docs/robustness.md)";
    } else {
      os << "the problem is too ill-conditioned even for the " << ToString(filter.form)
         << " form: rescale the state or check Q, R and P0";
    }
  }
  if (!h.nis_consistent) {
    if (h.cholesky_failures > 0) os << "; ";
    os << "the innovations are inconsistent with the model (mean normalized innovation squared " << h.nis_mean
       << " outside its 99% band [" << h.nis_lower << ", " << h.nis_upper << "]): Q, R or the model may not "
       << "fit the data";
  }
  return os.str();
}

}  // namespace kfx

namespace kfx::detail {

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
