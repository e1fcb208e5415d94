#pragma once
// How fast the sampled Kalman filter converges to the Kalman-Bucy filter (paper 003: Aalto, Int. J. Control,
// arXiv:1408.1275; docs/papers/README.md):
//   err(n) = E|z_{T,n} - z(T)|^2 = tr P_{T,n} - tr P_c(T)
// (z_{T,n} = E[z(T) | y(t_1..t_n)] is E[z(T) | F_c] conditioned on the coarser sigma algebra, so
// z(T) - zhat(T) is orthogonal to zhat(T) - z_{T,n}: Pythagoras; checked in the tests against the
// exact joint covariance), the a-posteriori bounds of Theorems 1-4 and Corollary 1, and the
// modal wave-equation model of Example 1. Corrections to the printed constants: docs/papers/003.md.
#include <Eigen/Dense>
#include <string>
#include <vector>

#include "kfx/continuous.hpp"
#include "kfx/progress.hpp"

namespace kfx {

/// The model-dependent quantities in the bounds (norms are spectral norms).
struct BoundConstants {
  double mu = 0.0;         ///< sup_{t in [0, T]} |e^{A t}| (grid of 2048 points, refined at the maximum)
  double norm_A = 0.0;     ///< |A|
  double norm_C = 0.0;     ///< |C|
  double min_eig_R = 0.0;  ///< min eig R
  double tr_P0 = 0.0;
  double tr_BQB = 0.0;         ///< tr(B Q B^T)
  double tr_ABQBA = 0.0;       ///< tr(A B Q B^T A^T)
  double tr_AP0A = 0.0;        ///< tr(A P0 A^T) (Theorem 4)
  double norm_P0_graph = 0.0;  ///< |P0|_{L(X, D(A))} = |[P0; A P0]| (graph norm of D(A), Theorem 3)
  int r = 0;                   ///< output dimension
};
BoundConstants ComputeBoundConstants(const ContinuousModel& model, double T);

/// The bounds on err(n) at one n, with E = E|z_{T,n} - z(T)|^2 = tr P_{T,n} (the a-posteriori
/// form the theorems state; the a-priori forms replace E by mu^2 tr P0 (+ T mu^2 tr B Q B^T)).
struct SamplingBounds {
  double theorem1 = 0.0;        ///< mu^2 trP0 E |C|^2 |A|^2 T^3 / (12 minR n^2)   (B = 0)
  double theorem2 = 0.0;        ///< as stated: M1 T^2/n + M2 T^3/n^2 + M3 T^4/n^2
  double theorem2_proof = 0.0;  ///< what its proof gives: M1 T^2/(2n) + M2 T^3/n^2 + (M3/2) T^4/n^2
  double theorem3 = 0.0;        ///< r mu^2 |P0|_{X,D(A)} |C|^2 E T^2 / (2 minR n)  (B = 0; mu^2 from the proof)
  double theorem4 = 0.0;        ///< mu^2 tr(A P0 A^T) |C|^2 E T^3 / (12 minR n^2)  (B = 0)
  double corollary1 = 0.0;      ///< M1 T^2/n + M3 T^4/n^2 + theorem4-term (case (ii))
};
SamplingBounds EvaluateSamplingBounds(const BoundConstants& c, double T, int n, double E);

struct ConvergencePoint {  ///< One sampling resolution n of a convergence study: tr P_{T,n}, its error and the bounds.
  int n = 0;               ///< sampling intervals on [0, T]
  double tr_P = 0.0;       ///< tr P_{T,n}
  double err = 0.0;        ///< tr P_{T,n} - tr P_c(T)
  SamplingBounds bounds;   ///< the error bounds at this n
};

struct ConvergenceStudyOptions {
  std::vector<int> n_values = {1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1024};
  int rate_min_n = 16;  ///< the rate is fitted over n >= rate_min_n
  ProgressCallback progress{};
};

struct ConvergenceStudy {                ///< Sampled filter vs Kalman-Bucy for growing n (003): points and the rate.
  double tr_Pc = 0.0;                    ///< tr P_c(T) (Kalman-Bucy, doubling)
  std::vector<ConvergencePoint> points;  ///< one per n
  double rate = 0.0;                     ///< least-squares slope of log err vs log n over n >= rate_min_n
  BoundConstants constants;
};

/// err(n) for each n (uniform sampling t_i = i T / n), the bounds and the fitted rate.
/// @throws kfx::Error on an invalid model, T, or n values (each >= 1).
ConvergenceStudy StudyConvergence(const ContinuousModel& model, double T,
                                  const ConvergenceStudyOptions& options = ConvergenceStudyOptions());

/// Least-squares slope of log y against log x over the points with x >= x_min and y > 0
/// (NaN if fewer than two such points).
double LogLogSlope(const std::vector<double>& x, const std::vector<double>& y, double x_min);

/// Example 1: the wave equation z_tt = z_ss on [0, 1] with zero initial displacement, in the
/// state space H_0^1 x L^2, truncated to the dyadic modes sin(2^k pi s), k = 1..K. Modal energy
/// coordinates (omega_k alpha_k, beta_k), omega_k = 2^k pi, make |z|_X Euclidean:
///   A = blockdiag([[0, omega_k], [-omega_k, 0]]),  C z = sum_k d_k (omega_k alpha_k),
///   P0 = blockdiag(diag(0, sigma_k^2)),  R scalar.
/// (d_k are the output coefficients in the energy basis; |C| = |d|_2.)
/// @throws kfx::Error unless sigma2 and d have the same number (>= 1) of entries, sigma2 >= 0, d finite and
///         R > 0 (ValidateContinuousModel).
ContinuousModel WaveModalModel(const std::vector<double>& sigma2, const std::vector<double>& d, double R);

}  // namespace kfx
