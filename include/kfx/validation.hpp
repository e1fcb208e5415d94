#pragma once
// Input validation shared by every kfx entry point. Each function throws kfx::Error with a
// message of the form "<name>: expected <what>, got <what>".
#include <Eigen/Dense>
#include <string>

#include "kfx/error.hpp"

namespace kfx {

/// Default relative tolerance of the symmetry check: |M - M^T|_max <= tol * max(1, |M|_max).
inline constexpr double kSymmetryTolerance = 1e-10;
/// Default relative tolerance of the semidefiniteness check (see RequirePositiveSemidefinite).
inline constexpr double kDefinitenessTolerance = 1e-12;

/// "3x4" for a matrix: the one way kfx writes a matrix shape in messages.
std::string ShapeString(const Eigen::Ref<const Eigen::MatrixXd>& m);
/// "3x4" for a rows x cols shape (no matrix needed, e.g. an expected shape).
std::string ShapeString(Eigen::Index rows, Eigen::Index cols);

/// Throws unless every entry is finite.
void RequireFinite(const std::string& name, const Eigen::Ref<const Eigen::MatrixXd>& m);
/// Throws unless m is rows x cols (a negative value means "any").
void RequireShape(const std::string& name, const Eigen::Ref<const Eigen::MatrixXd>& m, Eigen::Index rows,
                  Eigen::Index cols);
/// Throws unless m is square.
void RequireSquare(const std::string& name, const Eigen::Ref<const Eigen::MatrixXd>& m);
/// Throws unless m is square, finite and symmetric within tol (relative to max(1, |m|_max)).
void RequireSymmetric(const std::string& name, const Eigen::Ref<const Eigen::MatrixXd>& m,
                      double tol = kSymmetryTolerance);
/// Throws unless m is symmetric and positive semidefinite: the Cholesky factorization of
/// m + tol * max(1, max diag) * I succeeds.
void RequirePositiveSemidefinite(const std::string& name, const Eigen::Ref<const Eigen::MatrixXd>& m,
                                 double tol = kDefinitenessTolerance);
/// Throws unless m is symmetric and positive definite (Cholesky of m succeeds and its smallest
/// pivot is > tol * max diag).
void RequirePositiveDefinite(const std::string& name, const Eigen::Ref<const Eigen::MatrixXd>& m,
                             double tol = kDefinitenessTolerance);
/// Throws unless the vector has length n (negative: any) and is finite.
void RequireVector(const std::string& name, const Eigen::Ref<const Eigen::VectorXd>& v, Eigen::Index n);

/// 0.5 (m + m^T), in place.
void Symmetrize(Eigen::Ref<Eigen::MatrixXd> m);

}  // namespace kfx
