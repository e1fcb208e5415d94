#pragma once
// Private helpers shared by src/mismatch.cpp and src/mismatch_bounds.cpp (not installed).
#include <Eigen/Dense>
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
/// Kalman filter gain. Returns false with *why set if the DARE fails.
bool ResolveFilterGain(const ModelStep& design, const MismatchOptions& options, Eigen::MatrixXd* gain,
                       std::string* why);

/// The error matrix `e` of shape rows x cols, or zeros when it is empty.
Eigen::MatrixXd OrZeros(const Eigen::MatrixXd& e, Eigen::Index rows, Eigen::Index cols);

}  // namespace kfx::detail
