#pragma once
// Private: eigen-decomposition of small general real matrices through LAPACK DGEEV (one place, used
// by the bounds of 002 and 004; Eigen's EigenSolver is avoided for compile time).
#include <Eigen/Dense>

namespace kfx::detail {

/// Eigenvalues (and, if `vectors` is not null, unit-norm right eigenvectors as a complex matrix) by
/// LAPACK DGEEV. Returns false if the QR algorithm failed.
bool EigenDecompose(const Eigen::MatrixXd& a, Eigen::VectorXcd* values, Eigen::MatrixXcd* vectors);

/// Spectral condition number of a complex matrix, from the singular values of its real embedding
/// [[Re T, -Im T], [Im T, Re T]] (each singular value of T appears twice); inf if singular.
double ConditionNumber(const Eigen::MatrixXcd& t);

}  // namespace kfx::detail
