#pragma once
// Exact discretization of linear time-invariant continuous-time systems (matrix exponentials,
// Van Loan's block method; never Euler). Shared by the continuous-time module (paper 003), the
// spring-mass chain (paper 001) and anyone who builds a discrete model from an ODE.
//
// Continuous model:   dx = A x dt + B u dt + dw,   E[dw dw^T] = Qc dt.
// Sampled with step dt and u held constant over each step (zero-order hold):
//   x_k = Ad x_{k-1} + Bd u_{k-1} + w_k,   Ad = e^{A dt},   Bd = (int_0^dt e^{A s} ds) B,
//   E[w_k w_k^T] = Qd = int_0^dt e^{A s} Qc e^{A^T s} ds.
#include <Eigen/Dense>

namespace kfx {

/// e^M by Eigen's scaling-and-squaring Pade approximant (unsupported/MatrixFunctions).
/// @throws kfx::Error if M is not square or not finite; kfx::NumericalError if e^M overflows.
Eigen::MatrixXd MatrixExponential(const Eigen::MatrixXd& M);

/// Zero-order-hold sampling of (A, B) with step dt > 0: Ad = e^{A dt}, Bd = int_0^dt e^{A s} ds B,
/// from one exponential of the block matrix [[A, B], [0, 0]] dt (valid for singular A).
/// @throws kfx::Error if A is not square, B does not have A's rows, either is not finite, or dt is not
/// finite and > 0; kfx::NumericalError if the exponential overflows.
struct ZohDiscretization {
  Eigen::MatrixXd Ad;
  Eigen::MatrixXd Bd;
};
ZohDiscretization DiscretizeZoh(const Eigen::MatrixXd& A, const Eigen::MatrixXd& B, double dt);

/// Exact sampled process noise: Ad = e^{A dt} and Qd = int_0^dt e^{A s} Qc e^{A^T s} ds (symmetric,
/// PSD) by Van Loan's method: exp([[-A, Qc], [0, A^T]] dt) = [[*, E12], [0, E22]], Ad = E22^T,
/// Qd = E22^T E12. Qc must be symmetric positive semidefinite.
/// @throws kfx::Error if A is not square and finite, Qc not n x n symmetric PSD, or dt not finite and > 0;
/// kfx::NumericalError if the exponential overflows.
struct NoiseDiscretization {
  Eigen::MatrixXd Ad;
  Eigen::MatrixXd Qd;
};
NoiseDiscretization DiscretizeProcessNoise(const Eigen::MatrixXd& A, const Eigen::MatrixXd& Qc, double dt);

}  // namespace kfx
