#pragma once
// Private pieces shared by reduced_order.cpp and reduced_order_subspace.cpp.
#include <Eigen/Dense>
#include <chrono>
#include <functional>
#include <string>
#include <vector>

#include "kfx/reduced_order.hpp"

namespace kfx::detail {

/// Moore-Penrose pseudo-inverse of a symmetric PSD matrix by its eigen-decomposition, dropping
/// eigenvalues <= rank_tolerance * (largest |eigenvalue|); sets *singular when any is dropped.
Eigen::MatrixXd SymmetricPseudoInverse(const Eigen::MatrixXd& S, double rank_tolerance, bool* singular);

/// X V^{-1} for symmetric positive definite V (Cholesky). @throws kfx::NumericalError otherwise.
Eigen::MatrixXd SolveRight(const Eigen::MatrixXd& X, const Eigen::MatrixXd& V, const std::string& what);

/// The Summary of a schedule of T steps computed since `start` (a recursion: it either completes or
/// throws): kConverged, iterations = T, seconds, and a message listing the steps that used a
/// pseudo-inverse (singular_steps; may be null).
void FinishScheduleSummary(const char* computation, int T, std::chrono::steady_clock::time_point start,
                           const std::vector<int>* singular_steps, Summary* summary);

/// Validates options and weights against the model; returns T.
int PrepareRun(const Model& model, const WeightSchedule& L, const ReducedOrderOptions& options);

/// z_k = (xi_k, y_k); Ae[k-2], Be[k-2] for k >= 2; output(k) maps xi_k to an estimate of x_k.
LinearFilter OneStepFilter(const Eigen::VectorXd& xi1, const std::vector<Eigen::MatrixXd>& Ae,
                           const std::vector<Eigen::MatrixXd>& Be, const std::function<Eigen::MatrixXd(int)>& output,
                           Eigen::Index m, int T);

/// z_k = (xi^da_k, xi^f_k); Cf[k-1], Df[k-1] for k >= 1, Ad[k-2] for k >= 2.
LinearFilter TwoStepFilter(const Eigen::VectorXd& xi1, const std::vector<Eigen::MatrixXd>& Cf,
                           const std::vector<Eigen::MatrixXd>& Df, const std::vector<Eigen::MatrixXd>& Ad,
                           const std::function<Eigen::MatrixXd(int)>& output, TwoStepOutput which, int T);

}  // namespace kfx::detail
