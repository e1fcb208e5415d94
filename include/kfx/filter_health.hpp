#pragma once
// Health of a filter run (FilterRunOptions::monitor_health): symmetry and definiteness of the
// filtered covariances and consistency of the innovations (docs/robustness.md).
#include <limits>

namespace kfx {

struct FilterHealth {
  bool monitored = false;  ///< true when the run was asked to monitor (the fields below are then set)
  int steps = 0;           ///< steps checked
  /// max_k max_ij |P_ij - P_ji| / max_ij |P_ij| over the filtered covariances P_{k|k} as returned
  /// (0 when the filter symmetrizes).
  double max_asymmetry = 0.0;
  /// Smallest eigenvalue of any P_{k|k} (k >= 1), and the first step where it occurred.
  double min_eigenvalue = std::numeric_limits<double>::infinity();
  int min_eigenvalue_step = -1;
  /// Steps whose P_{k|k} has no Cholesky factor (not numerically positive definite), and the first.
  int cholesky_failures = 0;
  int first_cholesky_failure = -1;
  /// Normalized innovation squared: nis_sum = sum_k nu_k^T S_k^{-1} nu_k, chi-square with nis_dof
  /// (the number of observed entries) degrees of freedom when the model is right.
  double nis_sum = 0.0;
  long nis_dof = 0;
  double nis_mean = std::numeric_limits<double>::quiet_NaN();  ///< nis_sum / nis_dof, 1 when consistent
  /// Two-sided 99% band of nis_mean for a consistent filter (normal approximation 1 +- 2.576 sqrt(2/dof)).
  double nis_lower = std::numeric_limits<double>::quiet_NaN();
  double nis_upper = std::numeric_limits<double>::quiet_NaN();
  bool nis_consistent = true;  ///< nis_mean inside [nis_lower, nis_upper]
  /// True when every P_{k|k} had a Cholesky factor and the innovations were consistent.
  bool healthy() const { return cholesky_failures == 0 && nis_consistent; }
};

}  // namespace kfx
