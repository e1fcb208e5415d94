#pragma once
// Filters built on a wrong model: the exact true error and the Patel-Toda bounds (paper 002,
// R. Patel, M. Toda, "Modeling error analysis of stationary linear discrete-time filters", NASA TM
// X-73,225, NASA Ames Research Center, February 1977; docs/papers/README.md; corrections to the printed
// equations in docs/papers/002.md, symbols mapped in docs/notation.md).
//
// 002's system and filter, in kfx's notation (002's H is kfx's C, 002's G Q G^T is kfx's Q):
//   true:    x_k = A x_{k-1} + G w_k,  y_k = C x_k + v_k,   w ~ (0, Q), v ~ (0, R)
//   design:  A_M = A + dA, C_M = C + dC, Q_M = Q + dQ, R_M = R + dR   (Delta = model - true)
//   filter (10):  x^_k = A_M x^_{k-1} + K_M (y_k - C_M A_M x^_{k-1}),   K_M the design's gain,
// i.e. the kfx::LinearFilter Phi = L A_M, K = K_M, O = I with L = I - K_M C_M (ConstantGainFilter
// on the design step, or KalmanAsLinearFilter on the design model when the gain is time-varying).
// Its error x~ = x^ - x (002's sign: estimate minus truth) has the second moments
//   P = E[x~ x~^T], V = E[x x~^T], U = E[x x^T],
// which obey 002's recursions (15)-(17) with dC' = L dA - K_M dC A_M + K_M dC dA (19):
//   P_k = L A_M P_{k-1} A_M^T L^T + dC' V_{k-1} A_M^T L^T + L A_M V_{k-1}^T dC'^T + dC' U_{k-1} dC'^T
//         + (L + K_M dC) G Q G^T (L + K_M dC)^T + K_M R K_M^T
//   V_k = A V_{k-1} A_M^T L^T + A U_{k-1} dC'^T - G Q G^T (L + K_M dC)^T
//   U_k = A U_{k-1} A^T + G Q G^T
// where L, K_M are those of the gain that forms x^_k (K_M(k+1) in 002's indexing of (10); (15)-(16)
// print K_M(k)). These are an independent second algorithm to the exact-performance engine
// (performance.hpp), which evaluates the same filter through the joint covariance of (x, x^).
//
// Beyond 002 (issue 22): the truth may have a cross-covariance S_t = E[w_k v_k^T] (which a design without S
// does not model) and a known input, x_k gets G_t g_k and y_k gets D_t g_k, which the design's filter models
// by its own G_M, D_M (none: it ignores the input):
//   x^_k = A_M x^_{k-1} + G_M g_k + K_M (y_k - D_M g_k - C_M (A_M x^_{k-1} + G_M g_k)).
// S_t adds to the noise terms of (15)-(16): - (L + K_M dC) S_t K_M^T - K_M S_t^T (L + K_M dC)^T in P_k and
// + S_t K_M^T in V_k (E[w_k e_k^T] with e_k = -(L + K_M dC) w_k + K_M v_k). The input gives the error a
// deterministic mean: with the central moments Pc, Vc, Uc of (15)-(17) (+ the S terms),
//   E[x~_k] = L A_M E[x~_{k-1}] + dC' E[x_{k-1}] + b_k,   E[x_k] = A E[x_{k-1}] + G_t g_k,
//   b_k = L G_M g_k - (L + K_M dC) G_t g_k + K_M (D_t - D_M) g_k,
// and P = Pc + E[x~] E[x~]^T (likewise V, U): tr P = tr Pc + |E x~|^2 is the mean-square error.
// docs/papers/002.md ("Beyond 002") derives these and says which bounds still hold.
//
// The noise covariance of a step, in 002's sense, is the p x p covariance U of a noise input
// (ModelStep::B = G, ModelStep::U) when the step has one, and otherwise the n x n Q with G = I.
// Its error dQ has that shape.
#include <Eigen/Dense>
#include <optional>
#include <string>
#include <vector>

#include "kfx/model.hpp"
#include "kfx/summary.hpp"

namespace kfx {

/// Modelling errors in 002's convention Delta = model - true. An empty matrix means "no error".
struct ModelingErrors {
  Eigen::MatrixXd A{};  ///< n x n: dA = A_M - A
  Eigen::MatrixXd C{};  ///< m x n: 002's dH = C_M - C
  Eigen::MatrixXd Q{};  ///< p x p (noise input) or n x n: dQ = Q_M - Q (symmetric)
  Eigen::MatrixXd R{};  ///< m x m: dR = R_M - R (symmetric)
  /// n x m: dS = S_M - S_t, the cross-covariance's error (issue 22; a design without S: dS = -S_t).
  Eigen::MatrixXd S{};
};

/// The true step of a design step with errors: A = A_M - dA, C = C_M - dC, the noise covariance
/// minus dQ (with the design's noise input G, if any), R = R_M - dR, S = S_M - dS (none when both are
/// empty); the design's known input (G, D) is kept.
/// @throws kfx::Error naming the error matrix ("errors.A", ...) on a shape mismatch, non-finite or
///         asymmetric entries, or if the true Q is not PSD or the true R not PD.
ModelStep ApplyModelingErrors(const ModelStep& design, const ModelingErrors& errors);

/// design - truth, for two steps of the same dimensions and the same noise input G (both without
/// one, or both with the same B); dS when either has S. @throws kfx::Error otherwise.
ModelingErrors ModelingErrorsBetween(const ModelStep& design, const ModelStep& truth);

// ---- exact true error ------------------------------------------------------------------------

struct MismatchOptions {
  /// The filter gain K_M (n x m). Empty: the steady-state Kalman filter gain of the design step
  /// (SteadyStateDare: SolveFilterDare, with the design's S when it has one). 002's bounds hold for any gain
  /// (remark after Theorem 4).
  Eigen::MatrixXd filter_gain{};
  /// The constant known input g (length q) of the stationary analysis (issue 22): required when the design
  /// or the truth has G or D, none (empty) otherwise. Not for the bounds (Theorem 1 refuses it).
  Eigen::VectorXd input{};
  bool IsValid(std::string* error) const;
};

/// Stationary solution of (15)-(17) (002 Sec. 3): U from the Lyapunov equation U = A U A^T + G Q G^T
/// (SolveDiscreteLyapunov), V from the Sylvester equation V = A V (L A_M)^T + A U dC'^T
/// - G Q G^T (L + K_M dC)^T (SLICOT SB04QD), P from the Lyapunov equation of (15); with the truth's S its
/// terms, with a constant input g the stationary means E[x] = (I - A)^{-1} G_t g,
/// E[x~] = (I - L A_M)^{-1} (dC' E[x] + b) (b as above, constant).
struct StationaryMismatch {
  Eigen::MatrixXd filter_gain;          ///< K_M, n x m
  Eigen::MatrixXd P;                    ///< n x n, E[x~ x~^T] = Cov(x~) + E[x~] E[x~]^T (no input: the covariance)
  Eigen::MatrixXd V;                    ///< n x n, E[x x~^T] (002's sign)
  Eigen::MatrixXd U;                    ///< n x n, E[x x^T]
  Eigen::VectorXd error_mean;           ///< E[x~] (zero without a known input)
  Eigen::VectorXd state_mean;           ///< E[x]
  double trace = 0.0;                   ///< tr P = tr Cov(x~) + |E x~|^2, the MSE; 002's index (14)
  double true_spectral_radius = 0.0;    ///< rho(A)
  double filter_spectral_radius = 0.0;  ///< rho(L A_M)
  /// kConverged: stationary P, V, U computed; relative_residual = the largest relative residual
  /// |lhs - rhs|_F / max(|lhs|_F, tiny) of (15), (16), (17). kUnstable: rho(A) >= 1 (no stationary U,
  /// and with it P) or rho(L A_M) >= 1 (the filter's error grows); the message says which. The design
  /// DARE's termination when no filter_gain was given and that DARE failed ("design filter DARE: ...");
  /// kFailed / kSingular when a Lyapunov or Sylvester solve failed (message says which).
  Summary summary;
};

/// The stationary true error of the filter (10) designed on `design` and run on `truth`.
/// @param design, truth time-invariant steps of the same dimensions (n, m); the truth may have S, either may
///        have a known input (G, D; the same q).
/// @throws kfx::Error on invalid steps/options (dimensions, a filter_gain that is not n x m, a design with S whose
///         C Q C^T + C S + S^T C^T + R is not positive definite), naming options.input when it does not
///         fit the steps' G, D (required by a step with G or D, refused when neither has them).
/// Numerical outcomes (unstable system or filter, failed solves) are in summary.
StationaryMismatch StationaryMismatchedCovariance(const ModelStep& design, const ModelStep& truth,
                                                  const MismatchOptions& options = MismatchOptions());

/// (15)-(19) over k = 0..T for the time-varying filter (10): the gains are the Kalman filter gains
/// of `design` (ComputeKalmanSchedule, prior m0, P0 of the design), the filter starts at x^_0 =
/// design.m0(), and x_0 ~ N(truth.m0(), truth.P0()). Then P_0 = P0_t + d d^T (d = m0_M - m0_t),
/// V_0 = m0_t m0_M^T - U_0, U_0 = P0_t + m0_t m0_t^T (002 states P(0) = -V(0) = U(0) for a zero mean).
struct MismatchSequence {
  std::vector<Eigen::MatrixXd> P;            ///< k = 0..T: E[x~_k x~_k^T] (its trace is the MSE)
  std::vector<Eigen::MatrixXd> V;            ///< k = 0..T: E[x_k x~_k^T]
  std::vector<Eigen::MatrixXd> U;            ///< k = 0..T: E[x_k x_k^T]
  std::vector<Eigen::MatrixXd> filter_gain;  ///< k = 1..T (index 0 empty): K_M at step k
  Eigen::VectorXd trace;                     ///< length T+1: tr P_k = tr Cov(x~_k) + |E x~_k|^2
  TimeSeries error_mean;                     ///< (T+1) x n, row k = E[x~_k] (prior means, the known input)
  TimeSeries state_mean;                     ///< (T+1) x n, row k = E[x_k]
};

struct MismatchSequenceOptions {
  int steps = 0;  ///< T >= 0 (within both models' horizons)
};
/// Models may be time-varying; design and truth must have the same n, m. @throws kfx::Error on invalid
/// input; kfx::NumericalError (a recursion) if the design's Kalman schedule breaks down.
MismatchSequence MismatchedCovarianceSequence(const Model& design, const Model& truth,
                                              const MismatchSequenceOptions& options);
/// The same with the known input g (T x q, row k-1 = g_k; issue 22): the truth's G_t g_k, D_t g_k drive it,
/// the filter applies the design's G_M, D_M (none: it ignores the input). The truth may have S (the
/// design's own S only changes its gains). @throws kfx::Error as above, and naming g when it does not fit
/// a model that has G or D (kfx::RequireKnownInput), or has columns when neither has.
MismatchSequence MismatchedCovarianceSequence(const Model& design, const Model& truth, const TimeSeries& g,
                                              const MismatchSequenceOptions& options);

// ---- bounds (002 Secs. 3-5) -------------------------------------------------------------------

/// Element-wise error ranges |Delta X_ij| <= X(i, j) (002 Sec. 6), shapes as in ModelingErrors.
/// An empty matrix means that X is known exactly. Q and R must be symmetric.
struct ErrorRanges {
  Eigen::MatrixXd A, C, Q, R;
  /// n x m range of dS = S_M - S_t (issue 22): the truth's cross-covariance, for a design without S.
  Eigen::MatrixXd S{};
  /// The truth has a known input that the design's filter ignores or mis-models (G, D differ).
  bool unmodelled_input = false;
  /// True when every entry is zero (or the matrix is empty) for A and C (resp. Q and R).
  bool PlantExact() const;
  bool NoiseExact() const;
};

/// Checks shapes against the design (n x n, m x n, noise covariance shape, m x m, S n x m), finiteness,
/// non-negativity and symmetry of Q and R. @throws kfx::Error naming "ranges.A", ...
void ValidateErrorRanges(const ModelStep& design, const ErrorRanges& ranges);

/// Bounds on the error norms that the theorems use (|.| = Frobenius norm, 002's ||.||).
struct ErrorNorms {
  double A = 0.0, C = 0.0, Q = 0.0, R = 0.0;
  double S = 0.0;                   ///< |dS|_F (issue 22)
  double A_diagonal_abs_sum = 0.0;  ///< sum_i |dA_ii| (Theorem 6)
};
/// The largest values over the box: |dX|_F <= |range X|_F, sum |dA_ii| <= sum range A_ii.
ErrorNorms ErrorNormsFromRanges(const ErrorRanges& ranges);
/// The norms of given errors.
ErrorNorms ErrorNormsOf(const ModelingErrors& errors);

/// The parts of Theorem 1 that depend only on the design and the gain (002 (22)-(25)):
/// with F = L A_M, i^T M^{-1} b = tr X for X = F X F^T + B, B = L G Q_M G^T L^T + K_M R_M K_M^T,
/// and (M^{-1})^T i = cs(Y) for Y = F^T Y F + I, so |(M^{-1})^T i| = |Y|_F. No n^2 x n^2 matrix.
struct DesignTerms {
  Eigen::MatrixXd filter_gain;  ///< K_M
  Eigen::MatrixXd L;            ///< I - K_M C_M (24)
  Eigen::MatrixXd G;            ///< the noise input (I when the step has none)
  Eigen::MatrixXd noise_cov;    ///< Q_M in 002's sense (U, or Q)
  double nominal_trace = 0.0;   ///< i^T M^{-1} b
  double adjoint_norm = 0.0;    ///< |(M^{-1})^T i|
  double filter_spectral_radius = 0.0;
  /// kConverged; the design DARE's termination when no gain was given and it failed; kUnstable when
  /// rho(L A_M) >= 1 (no stationary filter error, no bound); a Lyapunov solve's failure.
  Summary summary;
};
/// @throws kfx::Error on invalid input. Numerical outcomes are in summary.
DesignTerms ComputeDesignTerms(const ModelStep& design, const MismatchOptions& options = MismatchOptions());

/// Theorem 1 (22)-(27) for known errors: tr P <= pi_1 = i^T M^{-1} b + |(M^{-1})^T i| |D|, with
///   D = L G Q_M G^T dC^T K_M^T + K_M dC G Q_M G^T (L + K_M dC)^T + dC' V A_M^T L^T + L A_M V^T dC'^T
///       + dC' U dC'^T - (L + K_M dC) G dQ G^T (L + K_M dC)^T - K_M dR K_M^T
/// (26) corrected: K_M for K_M^T, L A_M V^T for L A_M^T V^T), and with S (issue 22) the terms
/// H + H^T, H = L S_M K_M^T - (L + K_M dC) S_t K_M^T (b then holds - L S_M K_M^T - K_M S_M^T L^T). The identity
/// tr P = i^T M^{-1} (b + cs(D)) holds exactly (`identity_trace`), so the bound holds with S. A known input
/// (options.input) is refused: its mean terms are not in D.
struct Theorem1Result {
  double pi1 = 0.0;
  double D_norm = 0.0;          ///< |D|_F
  double identity_trace = 0.0;  ///< i^T M^{-1} (b + cs(D)), equal to tr P
  StationaryMismatch exact;     ///< the stationary (15)-(17) solution used for V and U
  /// kConverged, or the outcome of the design terms or of the stationary solution (exact.summary).
  Summary summary;
};
/// @throws kfx::Error on invalid input. Numerical outcomes are in summary.
Theorem1Result Theorem1Bound(const ModelStep& design, const ModelingErrors& errors,
                             const MismatchOptions& options = MismatchOptions());

/// Theorem 2 (28)-(31): tr P_F >= pi_2 = (-a2 + sqrt(a2^2 + 4 a1 a3)) / (2 a1) for the optimal
/// (Kalman) filter of `truth`, a1 = |A^T C^T R^{-1} C A|_s ((29) prints the exponent 5),
/// a2 = n + tr(C^T R^{-1} C Q) - sum_i |lambda_i(A)|^2, a3 = tr Q (kfx's Q = G Q G^T).
/// Not for a truth with S != 0: its optimal filter uses the correlation and can do better than pi_2
/// (docs/papers/002.md, "Beyond 002"). A known input does not change tr P_F.
/// @throws kfx::Error on an invalid step, or naming truth.S when the truth has a nonzero S.
double Theorem2Bound(const ModelStep& truth);

/// Theorem 3 (33), dA = 0, dC = 0: tr P <= pi_3 = i^T M^{-1} b + |(M^{-1})^T i| (|L G|_s^2 |dQ| +
/// |K_M|_s^2 |dR| + 2 |L|_s |K_M|_s |dS|) (the last term kfx's, for the truth's S: D gets L dS K_M^T + its
/// transpose). @throws kfx::Error unless norms.A == norms.C == 0 and terms.summary.ok().
double Theorem3Bound(const DesignTerms& terms, const ErrorNorms& norms);

/// How sum_i |lambda_i(A)|^2 enters Theorem 4's alpha_2 (36).
enum class EigenvalueTerm {
  kAsPrinted,     ///< sum_i |lambda_i(A)|^2, as (30) and (36) print it.
  kTraceSquared,  ///< (1/n) [tr A]^2 (smaller by Lemma 2, so the bound stays valid but is looser).
};

/// Theorem 4 (34)-(37), dA = 0, dC = 0: tr P_F >= pi_4 with
///   alpha_1 = |C A|_s^2 / (lambda_min(R_M) - |dR|), alpha_3 = tr(G Q_M G^T) - l |G|_s^2 |dQ|,
///   alpha_2 = n + |C G|_F^2 (|Q_M|_s + |dQ|) / (lambda_min(R_M) - |dR|) - sum_i |lambda_i(A)|^2,
/// l the noise dimension ((37) prints 2 for l; (40) derives l). Returns 0 (no information) when
/// lambda_min(R_M) <= |dR| or alpha_3 <= 0. @throws kfx::Error unless norms.A == norms.C == 0.
double Theorem4Bound(const ModelStep& design, const ErrorNorms& norms,
                     EigenvalueTerm eigenvalue_term = EigenvalueTerm::kAsPrinted);

/// The Lemma of Sec. 5: a bound on |U|_s for every true A = A_M - dA, |dA|_F <= norms.A, via the
/// Cayley transform F_M = (A_M^T + I)^{-1} (A_M^T - I) (42), with
///   c = |I - F_M|_s^2 (|dA|^2 + 2 |dA| |A_M|_s),  x = c kappa^2 / (-4 sigma),
///   sigma = max Re lambda(F_M) < 0,  kappa = cond(T) (T: eigenvectors of A_M, unit columns),
///   U_M: F_M^T U_M + U_M F_M = -(I - F_M^T) G Q G^T (I - F_M)  (U_M = 2 X for X = A_M X A_M^T + G Q G^T).
/// (41) as printed: beta = |U_M|_s / 2 exp(2 x). Its proof applies the Bellman-Gronwall lemma to a
/// constant; what the proof's inequality |U| <= |U_M|/2 + x |U| gives is |U|_s <= |U_M|_s / 2 / (1 - x)
/// for x < 1. exp(2x) >= 1 / (1 - x) only for x <= 0.7968, and (41) fails beyond that
/// (docs/papers/002.md has a scalar counterexample).
struct LemmaBound {
  double beta_printed = 0.0;  ///< (41) as printed
  double beta = 0.0;          ///< |U_M|_s / 2 / (1 - x); +inf when x >= 1 (no bound)
  double x = 0.0;
  double kappa = 0.0;
  double sigma = 0.0;
  double UM_norm = 0.0;  ///< |U_M|_s
  /// True when x <= 0.7968..., where (41) is implied by the sound bound.
  bool printed_is_valid = false;
  /// kConverged: the Lemma applies and the fields above are set. kUnstable: A_M is not stable
  /// (max Re lambda(F_M) >= 0); kSingular: A_M has the eigenvalue -1 (no Cayley transform (42));
  /// kUndecided: A_M is not (numerically) diagonalizable; kFailed: an eigendecomposition failed.
  Summary summary;
  bool applies() const { return summary.ok(); }
};
/// @throws kfx::Error on an invalid design step or a negative norm.
LemmaBound LemmaStateBound(const ModelStep& design, double dA_norm);

/// Theorem 5 (46), dQ = 0, dR = 0: tr P <= pi_5 = (mu_1 + sqrt(mu_1^2 + mu_2))^2 with
///   d = |L|_s |dA| + |K_M|_s |A_M|_s |dC| + |K_M|_s |dC| |dA|   ((48) prints |dA| in the middle term),
///   mu_1 = sqrt(beta) |(M^{-1})^T i| |L A_M|_s d,
///   mu_2 = i^T M^{-1} b + |(M^{-1})^T i| [beta d^2 + |K_M|_s^2 |G Q G^T|_s |dC|^2 + 2 |K_M|_s |L G Q G^T|_s |dC|].
struct Theorem5Result {
  double pi5 = 0.0;          ///< with the sound Lemma bound (lemma.beta); +inf when that does not exist
  double pi5_printed = 0.0;  ///< with (41) as printed (lemma.beta_printed): the paper's number
  LemmaBound lemma;
};
/// @throws kfx::Error unless norms.Q == norms.R == 0 and terms.summary.ok().
Theorem5Result Theorem5Bound(const ModelStep& design, const DesignTerms& terms, const ErrorNorms& norms);

/// Theorem 6 (50), dQ = 0, dR = 0: tr P_F >= pi_6 with gamma_1 = (|C_M|_s + |dC|)^2 |R^{-1}|_s
/// (|A_M|_s + |dA|)^2, gamma_2 = n + (|C_M|_s + |dC|)^2 |R^{-1}|_s tr(G Q G^T)
/// - (1/n) [max(0, |tr A_M| - sum |dA_ii|)]^2, gamma_3 = tr(G Q G^T). (The max(0, .) is needed when
/// sum |dA_ii| > |tr A_M|; 002 omits it.) @throws kfx::Error unless norms.Q == norms.R == 0.
double Theorem6Bound(const ModelStep& design, const ErrorNorms& norms);

/// Every bound of Theorems 3-6 that applies to the ranges (3, 4: plant exact; 5, 6: noise exact;
/// all four when the ranges are all zero), except those `refused` lists (S range, unmodelled input). @throws kfx::Error
/// (ComputePatelTodaBounds) for an invalid design step, a range of the wrong shape, non-finite, negative or (Q, R) not
/// symmetric, or a filter gain that is not n x m and finite.
struct PatelTodaBounds {
  ErrorNorms norms;
  DesignTerms terms;
  std::optional<double> pi3, pi4, pi5, pi5_printed, pi6;
  std::optional<LemmaBound> lemma;
  /// The bounds left unset because they do not hold for these ranges, each "piN: why" (issue 22): with a
  /// nonzero S range pi4, pi6 (the truth's optimal filter uses S and can beat them) and pi5 (no S term);
  /// with an unmodelled input pi3, pi5 (the error's mean is not bounded by the ranges). pi3 holds with S.
  std::vector<std::string> refused;
  Summary summary;  ///< kConverged, or the design terms' outcome (terms.summary; no bound is then set)
};
/// @throws kfx::Error on invalid input. Numerical outcomes are in summary.
PatelTodaBounds ComputePatelTodaBounds(const ModelStep& design, const ErrorRanges& ranges,
                                       const MismatchOptions& options = MismatchOptions());

// ---- tightest values over an error box ---------------------------------------------------------

struct ErrorBoxSearchOptions {
  /// All 2^d corners are evaluated when the number d of free entries is at most this; otherwise
  /// `random_corners` corners drawn with a fixed seed. Range [0, 24].
  int max_corner_dimensions = 12;
  int random_corners = 4096;  ///< >= 1
  /// Local refinement (compass search inside the box) from the best corner and from the centre.
  bool refine = true;
  /// Refinement stops when every step is below this fraction of its range; range (0, 1).
  double step_tolerance = 1e-7;
  int max_evaluations = 20000;  ///< per extreme, >= 1
  bool IsValid(std::string* error) const;
};

/// One extreme of a function over the box.
struct ErrorBoxExtreme {
  bool found = false;            ///< false if no point of the box gave a value (all invalid)
  double value = 0.0;            ///< tr P (least upper bound) or tr P_F (greatest lower bound)
  ModelingErrors errors;         ///< where it sits (Delta = model - true)
  ModelStep truth;               ///< the true step there
  bool at_corner = false;        ///< every free entry at +- its range
  int evaluations = 0;           ///< function evaluations (corners + refinement)
  int skipped = 0;               ///< points skipped: invalid truth (Q not PSD, R not PD), unstable, failed solve
  int corners = 0;               ///< corners evaluated
  double refinement_gain = 0.0;  ///< improvement of the refinement over the best corner
};

struct ErrorBoxSearch {
  int free_entries = 0;
  ErrorBoxExtreme least_upper;     ///< max tr P of the filter designed on `design` (fixed gain)
  ErrorBoxExtreme greatest_lower;  ///< min tr P_F of the optimal filter of the true system (SteadyStateDare)
  /// kConverged (the search ran; each extreme says whether it found a value), or the design DARE's
  /// termination when no gain was given and it failed (no search); iterations = evaluations.
  Summary summary;
};

/// Searches the box of true systems design - Delta, |Delta_ij| <= ranges_ij, for the largest true
/// error tr P of the design's filter and the smallest optimal error tr P_F (002 Sec. 6, the numbers in
/// parentheses). Corners first, then a compass search; the result is a value attained in the box
/// (a lower estimate of the supremum, an upper estimate of the infimum).
/// @throws kfx::Error on invalid input, and naming ranges.S / ranges.unmodelled_input when they are set (the
///         search varies A, C, Q, R only). Numerical outcomes are in summary.
ErrorBoxSearch SearchErrorBox(const ModelStep& design, const ErrorRanges& ranges,
                              const MismatchOptions& options = MismatchOptions(),
                              const ErrorBoxSearchOptions& search = ErrorBoxSearchOptions());

}  // namespace kfx
