#pragma once
// Continuous-time linear systems with integrated observations (paper 003: A. Aalto, "Convergence of
// discrete time Kalman filter estimate to continuous time estimate", International Journal of Control,
// arXiv:1408.1275; full reference in docs/papers/README.md; notation: docs/notation.md,
// docs/papers/003.md):
//
//   dz = A z dt + B du,   dy = C z dt + dw,   z(0) ~ N(m0, P0),
//
// u and w independent Brownian motions with incremental covariances Q (q x q) and R (r x r).
// Sampling y at 0 < t_1 < ... < t_n (t_0 = 0, y(0) = 0) gives the measurements
//   y_k = y(t_k) - y(t_{k-1}) = C int_{t_{k-1}}^{t_k} z ds + (w(t_k) - w(t_{k-1})),
// whose signal part correlates with the process noise over the same step. kfx handles that
// correlation exactly by augmenting the state with the step integral of z:
//   x_k = [z(t_k); iota_k],  iota_k = int_{t_{k-1}}^{t_k} z ds,
//   x_k = [[e^{A h}, 0], [int_0^h e^{A s} ds, 0]] x_{k-1} + w_k,   y_k = [0, C] x_k + v_k,
//   Cov w_k = Van Loan integral of the joint (z, int z) process,     Cov v_k = h_k R,
// an ordinary kfx::Model, so the discrete Kalman filter, its schedule and the exact-performance
// engine apply unchanged. The z-block of P_{k|k} at k = n is P_{T,n} of the paper.
//
// The Kalman-Bucy filter: P' = A P + P A^T + B Q B^T - P C^T R^{-1} C P, P(0) = P0, solved by
// the Hamiltonian matrix exponential over a short step and doubling (never fixed-step Euler);
// CARE A P + P A^T + B Q B^T - P C^T R^{-1} C P = 0 by SLICOT SB02OD.
#include <Eigen/Dense>
#include <cstdint>
#include <string>
#include <vector>

#include "kfx/model.hpp"
#include "kfx/riccati.hpp"
#include "kfx/summary.hpp"

namespace kfx {

/// The continuous-time model (1) of paper 003. No input noise: B and Q empty (or B p x 0, Q 0 x 0).
/// The Python constructor checks it (ValidateContinuousModel): @throws kfx::Error naming the matrix at fault
/// for wrong shapes, non-finite entries, Q or P0 not symmetric PSD, R not symmetric PD.
struct ContinuousModel {
  Eigen::MatrixXd A;   ///< p x p
  Eigen::MatrixXd B;   ///< p x q
  Eigen::MatrixXd C;   ///< r x p
  Eigen::MatrixXd Q;   ///< q x q incremental covariance of u (symmetric PSD)
  Eigen::MatrixXd R;   ///< r x r incremental covariance of w (symmetric PD)
  Eigen::VectorXd m0;  ///< p
  Eigen::MatrixXd P0;  ///< p x p (symmetric PSD)

  Eigen::Index state_dim() const { return A.rows(); }
  Eigen::Index output_dim() const { return C.rows(); }
  /// B Q B^T (p x p; zero when B has no columns).
  Eigen::MatrixXd ProcessNoise() const;
};

/// Checks dimensions, finiteness, Q and P0 symmetric PSD, R symmetric PD.
/// @throws kfx::Error naming the offending argument.
void ValidateContinuousModel(const ContinuousModel& model);

/// Exact discretization of the joint (z, int z) process over one step h > 0 (no input):
///   z(t+h)           = Phi z(t) + w,       Phi = e^{A h},
///   int_t^{t+h} z ds = Gamma z(t) + omega, Gamma = int_0^h e^{A s} ds,
/// Cov [w; omega] = [[Qzz, Qzi], [Qzi^T, Qii]] = int_0^h e^{F s} G e^{F^T s} ds with
/// F = [[A, 0], [I, 0]], G = blockdiag(Qc, 0) (Van Loan, DiscretizeProcessNoise on F).
struct IntegratedDiscretization {
  Eigen::MatrixXd Phi, Gamma;
  Eigen::MatrixXd Qzz, Qzi, Qii;
};
/// @param Qc p x p symmetric PSD (B Q B^T). @throws kfx::Error on invalid input.
IntegratedDiscretization DiscretizeIntegrated(const Eigen::MatrixXd& A, const Eigen::MatrixXd& Qc, double h);

/// The sampled model at times 0 < t_1 < ... < t_n (strictly increasing, finite) as a
/// time-varying kfx::Model with the augmented state x_k = [z(t_k); iota_k] (dimension 2p),
/// measurement y_k = y(t_k) - y(t_{k-1}) (dimension r), prior [m0; 0], blockdiag(P0, 0).
/// @throws kfx::Error on an invalid model or times.
Model SampledModel(const ContinuousModel& model, const std::vector<double>& times);
/// Uniform sampling t_i = i T / n: a time-invariant Model with horizon n.
Model SampledModel(const ContinuousModel& model, double T, int n);

/// The times i T / n, i = 1..n.
std::vector<double> UniformTimes(double T, int n);

/// The sampled filter's error covariance P_{T,n} (the z-block of P_{n|n}) at the last time, from
/// the Kalman schedule of SampledModel. @throws kfx::Error on invalid input.
Eigen::MatrixXd SampledFilterCovariance(const ContinuousModel& model, const std::vector<double>& times);
Eigen::MatrixXd SampledFilterCovariance(const ContinuousModel& model, double T, int n);

/// The Riccati flow over a step h as the linear-fractional map
///   P -> Delta + Phi P (I + Gamma P)^{-1} Phi^T   (Gamma, Delta symmetric PSD),
/// composed by the doubling formulas of the structure-preserving doubling algorithm.
struct RiccatiFlow {
  double h = 0.0;
  Eigen::MatrixXd Phi, Gamma, Delta;
  /// Applies the map to a symmetric PSD P.
  Eigen::MatrixXd Apply(const Eigen::MatrixXd& P) const;
};
/// The map of `first` followed by `second` (step first.h + second.h).
RiccatiFlow ComposeRiccatiFlows(const RiccatiFlow& first, const RiccatiFlow& second);
/// The flow over h > 0: the Hamiltonian exponential exp([[-A^T, C^T R^{-1} C], [B Q B^T, A]] h/2^k)
/// with k the smallest integer making the scaled Hamiltonian's 1-norm <= 1/2, then k doublings.
RiccatiFlow KalmanBucyFlow(const ContinuousModel& model, double h);

/// P_c(T): the Kalman-Bucy error covariance at time T >= 0 (P_c(0) = P0).
/// @throws kfx::Error on an invalid model (ValidateContinuousModel) or T not finite and >= 0.
Eigen::MatrixXd KalmanBucyCovariance(const ContinuousModel& model, double T);

/// Continuous algebraic Riccati equation of the filter, A P + P A^T + B Q B^T - P C^T R^{-1} C P = 0:
/// SolveFilterCare(A, C, B Q B^T, R, S = none, E = none) of include/kfx/riccati.hpp (SLICOT SB02OD,
/// DICO = 'C', on the dual problem (A^T, C^T, B Q B^T, R); CareSolution there).
/// @throws kfx::Error on an invalid model. Numerical outcomes are in summary.
CareSolution SolveFilterCare(const ContinuousModel& model);

/// Exact simulation of (z, y) on the grid t_i = i T / N (the augmented sampled model, so z(t_i)
/// and the increments of y have exactly the continuous model's joint law).
/// @throws kfx::Error on an invalid model, T not finite and > 0, or N < 1.
struct ContinuousTrajectory {
  std::vector<double> t;  ///< N + 1 times, t[0] = 0
  TimeSeries z;           ///< (N+1) x p, row i = z(t_i)
  TimeSeries dy;          ///< N x r, row i-1 = y(t_i) - y(t_{i-1})
};
ContinuousTrajectory SimulateContinuous(const ContinuousModel& model, double T, int N, std::uint64_t seed);

/// The sampled filter on increments dy over the grid i T / n (n = dy.rows()): returns z_{T,n}.
/// @throws kfx::Error on an invalid model, T not finite and > 0, no row of dy, dy without r columns or
///         with an infinite entry.
Eigen::VectorXd SampledFilterEstimate(const ContinuousModel& model, double T, const TimeSeries& dy);

/// The Kalman-Bucy filter d zhat = A zhat dt + K(t) (dy - C zhat dt), K = P C^T R^{-1}, driven by
/// the piecewise-linear interpolant of the observed path y on the uniform grid of dy (the
/// Wong-Zakai approximation; exact in the limit of a fine grid since K is deterministic), with P(t)
/// from the Riccati flow and the ODE for zhat integrated by classical RK4 with `substeps` steps per
/// grid interval. Returns zhat(T) and P_c(T).
/// @throws kfx::Error on an invalid model, T not finite and > 0, dy not (N >= 1, r) or not finite,
///         substeps < 1.
struct KalmanBucyRun {
  Eigen::VectorXd z_hat;  ///< estimate at T
  Eigen::MatrixXd P;      ///< P_c(T)
};
KalmanBucyRun RunKalmanBucy(const ContinuousModel& model, double T, const TimeSeries& dy, int substeps = 2);

}  // namespace kfx
