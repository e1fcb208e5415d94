// A program that uses kfx as a library user would: a DARE and a filter run, each checked against an
// independent truth. Built by tests/install/run.sh against an installed tree (CMake package or
// pkg-config) or with kfx added by add_subdirectory, at the compiler's default language standard.
#include <kfx/kalman_filter.hpp>
#include <kfx/riccati.hpp>

#include <cmath>
#include <cstdio>

// kfx must not put its own build settings into this program's compile flags.
#ifdef EIGEN_USE_BLAS
#error "EIGEN_USE_BLAS reached a consumer of kfx::kfx"
#endif
#ifdef KFX_VERSION
#error "KFX_VERSION reached a consumer of kfx::kfx"
#endif

int main() {
  // Scalar random walk: P = (q + sqrt(q^2 + 4 q r)) / 2 in closed form.
  const double q = 0.3, r = 2.0;
  const Eigen::MatrixXd one = Eigen::MatrixXd::Ones(1, 1);
  const kfx::DareSolution s1 = kfx::SolveFilterDare(one, one, q * one, r * one);
  const double closed = (q + std::sqrt(q * q + 4 * q * r)) / 2;
  const double err1 = std::abs(s1.P_pred(0, 0) - closed) / closed;

  // Three states, one output: the DARE residual, and the filter's P_{k|k-1} after many steps
  // (the Riccati recursion, a second algorithm) against the DARE's solution.
  Eigen::MatrixXd A(3, 3), C(1, 3), Q = 0.1 * Eigen::MatrixXd::Identity(3, 3), R = one;
  A << 0.9, 0.2, 0.0, -0.1, 0.8, 0.3, 0.0, 0.1, 0.7;
  C << 1.0, 0.5, -0.2;
  const kfx::DareSolution s = kfx::SolveFilterDare(A, C, Q, R);
  const Eigen::MatrixXd& P = s.P_pred;
  const Eigen::MatrixXd S = C * P * C.transpose() + R;
  const Eigen::MatrixXd residual =
      A * P * A.transpose() - P - A * P * C.transpose() * S.inverse() * C * P * A.transpose() + Q;
  const double dare_residual = residual.norm() / P.norm();
  const kfx::Model model(kfx::MakeStep(A, C, Q, R), Eigen::VectorXd::Zero(3), Eigen::MatrixXd::Identity(3, 3));
  const kfx::TimeSeries y = kfx::TimeSeries::Zero(300, 1);
  const kfx::FilterRun run = kfx::RunFilter(model, y);
  const double filter_gap = (run.P_pred.back() - P).norm() / P.norm();

  std::printf("C++ %ld; scalar DARE relative error %.3g; DARE residual %.3g; filter P vs DARE %.3g\n",
              static_cast<long>(__cplusplus), err1, dare_residual, filter_gap);
  const bool ok = s1.summary.ok() && s.summary.ok() && err1 < 1e-12 && dare_residual < 1e-12 && filter_gap < 1e-10;
  return ok ? 0 : 1;
}
