#pragma once
// Private helpers shared by mismatch.cpp and mismatch_bounds.cpp.
#include <Eigen/Dense>
#include <chrono>
#include <string>

#include "kfx/mismatch.hpp"

namespace kfx::detail {

/// Largest singular value |M|_s (0 for an empty matrix).
double SpectralNorm(const Eigen::Ref<const Eigen::MatrixXd>& m);

/// 002's G and noise covariance of a step: (B, U) for a step with a noise input, else (I, Q).
void NoiseInputOf(const ModelStep& step, Eigen::MatrixXd* G, Eigen::MatrixXd* noise_cov);

/// Checks a design step (dimensions, definiteness) with messages prefixed by `label`.
void ValidateDesignStep(const ModelStep& step, const std::string& label);

/// K_M: options.filter_gain when given (checked to be n x m), else the design's steady-state
/// Kalman filter gain. Returns false, with the DARE's outcome adopted by *summary (message "design
/// filter DARE: ..."), if that DARE fails.
bool ResolveFilterGain(const ModelStep& design, const MismatchOptions& options, Eigen::MatrixXd* gain,
                       Summary* summary);

/// Solves the Stein equation X = A X A^T + Q; false, with the failure adopted by *summary (message
/// "<what>: ..."), if the solve did not succeed.
bool SolveStein(const Eigen::MatrixXd& A, const Eigen::MatrixXd& Q, const std::string& what, Eigen::MatrixXd* X,
                Summary* summary);

/// Sets the computation name and the elapsed time since `start`.
void FinishSummary(const char* computation, std::chrono::steady_clock::time_point start, Summary* summary);

/// The error matrix `e` of shape rows x cols, or zeros when it is empty.
Eigen::MatrixXd OrZeros(const Eigen::MatrixXd& e, Eigen::Index rows, Eigen::Index cols);

}  // namespace kfx::detail
