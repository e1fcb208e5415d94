#pragma once
// Test helpers: matrix comparison with an explicit tolerance, seeded random systems.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cstdint>
#include <limits>
#include <random>
#include <sstream>
#include <string>
#include <utility>

#include "kfx/model.hpp"
#include "kfx/riccati.hpp"

namespace kfx::testing {

/// Fails unless max |a - b| <= tol (absolute) and the shapes agree. No default tolerance on purpose.
inline ::testing::AssertionResult MatricesNear(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b, double tol) {
  if (a.rows() != b.rows() || a.cols() != b.cols()) {
    return ::testing::AssertionFailure() << "shape " << a.rows() << "x" << a.cols() << " vs " << b.rows() << "x"
                                         << b.cols();
  }
  if (a.size() == 0) return ::testing::AssertionSuccess();
  const double diff = (a - b).cwiseAbs().maxCoeff();
  if (!(diff <= tol)) {
    std::ostringstream os;
    os << "max |a - b| = " << diff << " > tol " << tol;
    if (a.size() <= 36) os << "\na =\n" << a << "\nb =\n" << b;
    return ::testing::AssertionFailure() << os.str();
  }
  return ::testing::AssertionSuccess();
}

#define EXPECT_MATRICES_NEAR(a, b, tol) EXPECT_TRUE(::kfx::testing::MatricesNear((a), (b), (tol)))
#define ASSERT_MATRICES_NEAR(a, b, tol) ASSERT_TRUE(::kfx::testing::MatricesNear((a), (b), (tol)))

/// Relative Frobenius difference |a - b|_F / max(|b|_F, tiny); infinity when the shapes differ (a
/// comparison that fails instead of reading past the smaller matrix).
inline double RelativeDifference(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  if (a.rows() != b.rows() || a.cols() != b.cols()) return std::numeric_limits<double>::infinity();
  return (a - b).norm() / std::max(b.norm(), 1e-300);
}

/// Deterministic Gaussian matrices for tests (std::normal_distribution is fine here: tests only).
/// Draw in separate statements, never two draws in one argument list: the order in which function
/// arguments are evaluated is unspecified (GCC evaluates them right to left, Clang left to right), so
/// `MakeStep(rng.A(), rng.C(), ...)` is a different system under each compiler (docs/robustness.md,
/// "Sanitizer findings"). Tests rewritten for this draw in GCC's former order, last argument first, to
/// keep the systems their tolerances were set on.
class TestRng {
 public:
  explicit TestRng(std::uint64_t seed) : gen_(seed) {}
  Eigen::MatrixXd Gaussian(Eigen::Index r, Eigen::Index c) {
    Eigen::MatrixXd m(r, c);
    for (Eigen::Index j = 0; j < c; ++j)
      for (Eigen::Index i = 0; i < r; ++i) m(i, j) = dist_(gen_);
    return m;
  }
  /// Symmetric positive definite: G G^T / c + shift I.
  Eigen::MatrixXd Spd(Eigen::Index n, double shift = 0.1) {
    Eigen::MatrixXd g = Gaussian(n, n);
    Eigen::MatrixXd s = g * g.transpose() / static_cast<double>(std::max<Eigen::Index>(n, 1));
    s.diagonal().array() += shift;
    return 0.5 * (s + s.transpose());
  }
  /// A random matrix scaled to spectral radius rho.
  Eigen::MatrixXd WithSpectralRadius(Eigen::Index n, double rho) {
    Eigen::MatrixXd a = Gaussian(n, n);
    // kfx::SpectralRadius, not a.eigenvalues(): one EigenSolver instantiation in the library
    // instead of one per test file (compile time).
    return a * (rho / kfx::SpectralRadius(a));
  }

 private:
  std::mt19937_64 gen_;
  std::normal_distribution<double> dist_;
};

/// MakeStep(A, C, Q, R) with A n x n of spectral radius rho, C m x n Gaussian, Q = Spd(n, q_shift) and
/// R = Spd(m, r_shift), drawn in the order R, Q, C, A: the order in which GCC evaluated the former
/// one-statement `MakeStep(rng.WithSpectralRadius(n, rho), rng.Gaussian(m, n), rng.Spd(n), rng.Spd(m))`,
/// so the seeded tests keep the systems their tolerances were set on.
inline ModelStep RandomModelStep(TestRng& rng, Eigen::Index n, Eigen::Index m, double rho, double q_shift = 0.1,
                                 double r_shift = 0.1) {
  Eigen::MatrixXd R = rng.Spd(m, r_shift);
  Eigen::MatrixXd Q = rng.Spd(n, q_shift);
  Eigen::MatrixXd C = rng.Gaussian(m, n);
  Eigen::MatrixXd A = rng.WithSpectralRadius(n, rho);
  return MakeStep(std::move(A), std::move(C), std::move(Q), std::move(R));
}

}  // namespace kfx::testing
