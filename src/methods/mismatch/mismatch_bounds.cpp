// The bounds of paper 002 (Patel, Toda 1977), Theorems 1-6 and the Lemma of Sec. 5. API, equations
// and the corrections to the printed formulas: include/kfx/mismatch.hpp, docs/papers/002.md.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <complex>
#include <limits>
#include <vector>

#include "base/lapack_eigen.hpp"
#include "kfx/error.hpp"
#include "kfx/mismatch.hpp"
#include "kfx/riccati.hpp"
#include "kfx/validation.hpp"
#include "methods/mismatch/mismatch_internal.hpp"

namespace kfx {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

/// The positive root of a1 t^2 + a2 t - a3 = 0 (002 (28)), written 2 a3 / (a2 + sqrt(a2^2 + 4 a1 a3))
/// to avoid cancellation and to cover a1 = 0. Returns 0 (no information) when a3 <= 0, or when the
/// inequality has no positive solution (a1 = 0, a2 <= 0: the theorem's assumptions do not hold).
double QuadraticLowerRoot(double a1, double a2, double a3) {
  if (!(a3 > 0.0)) return 0.0;
  const double den = a2 + std::sqrt(a2 * a2 + 4.0 * a1 * a3);
  return den > 0.0 ? 2.0 * a3 / den : 0.0;
}

/// The x at which exp(2x) = 1 / (1 - x) (x > 0): below it, (41) as printed is implied by the sound
/// bound |U_M| / 2 / (1 - x).
double PrintedLemmaLimit() {
  double lo = 0.5, hi = 0.99;
  for (int it = 0; it < 100; ++it) {
    const double mid = 0.5 * (lo + hi);
    (2.0 * mid + std::log1p(-mid) > 0.0 ? lo : hi) = mid;
  }
  return lo;
}

double MinEigenvalueSym(const MatrixXd& m) {
  return Eigen::SelfAdjointEigenSolver<MatrixXd>(0.5 * (m + m.transpose()), Eigen::EigenvaluesOnly)
      .eigenvalues()
      .minCoeff();
}

void RequireNorms(const ErrorNorms& e) {
  const double v[6] = {e.A, e.C, e.Q, e.R, e.A_diagonal_abs_sum, e.S};
  const char* names[6] = {"|dA|_F", "|dC|_F", "|dQ|_F", "|dR|_F", "sum |dA_ii|", "|dS|_F"};
  for (int i = 0; i < 6; ++i) {
    if (!(v[i] >= 0.0) || !std::isfinite(v[i])) {
      throw Error(std::string("norms: expected finite non-negative error norms, got ") + names[i] + " = " +
                  std::to_string(v[i]) + " (for error ranges: their norm exceeds the range of double)");
    }
  }
}

void RequirePlantExact(const ErrorNorms& e, const char* theorem) {
  RequireNorms(e);
  if (e.A != 0.0 || e.C != 0.0) {
    throw Error(std::string("norms: ") + theorem +
                " needs dA = 0 and dC = 0 (noise covariance errors only), got |dA| = " + std::to_string(e.A) +
                ", |dC| = " + std::to_string(e.C));
  }
}

bool HasNonzeroS(const ModelStep& s) { return s.has_cross_covariance() && s.S.cwiseAbs().maxCoeff() > 0.0; }

// Theorems 2, 4, 5 and 6 have no S term (docs/papers/002.md, "Beyond 002"): refused for a truth with S.
void RequireNoCrossCovariance(const ErrorNorms& e, const ModelStep& design, const char* theorem) {
  if (e.S != 0.0 || HasNonzeroS(design)) {
    throw Error(std::string("norms: ") + theorem +
                " does not hold when the truth has a cross-covariance S (|dS| = " + std::to_string(e.S) +
                (HasNonzeroS(design) ? ", the design's S nonzero" : "") + "): see docs/papers/002.md, Beyond 002");
  }
}

// -L S_M K^T - K S_M^T L^T: the design's own S in b (zero without S).
MatrixXd DesignCrossTerm(const ModelStep& design, const MatrixXd& L, const MatrixXd& K) {
  if (!design.has_cross_covariance()) return MatrixXd::Zero(L.rows(), L.rows());
  const MatrixXd H = L * design.S * K.transpose();
  return -(H + H.transpose());
}

void RequireComputedTerms(const DesignTerms& terms) {
  if (!terms.summary.ok()) {
    throw Error("terms: expected computed design terms, got terms that ended " +
                std::string(ToString(terms.summary.termination)) + ": " + terms.summary.message);
  }
}

void RequireNoiseExact(const ErrorNorms& e, const char* theorem) {
  RequireNorms(e);
  if (e.Q != 0.0 || e.R != 0.0) {
    throw Error(std::string("norms: ") + theorem + " needs dQ = 0 and dR = 0 (plant errors only), got |dQ| = " +
                std::to_string(e.Q) + ", |dR| = " + std::to_string(e.R));
  }
}

}  // namespace

DesignTerms ComputeDesignTerms(const ModelStep& design, const MismatchOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  std::string why;
  if (!options.IsValid(&why)) throw Error("options." + why);
  detail::ValidateDesignStep(design, "design: ");
  DesignTerms t;
  Summary& sum = t.summary;
  sum.method = "two Lyapunov equations (22)-(25)";
  const auto finish = [&]() {
    detail::FinishSummary("Patel-Toda design terms", start, &sum);
    return std::move(t);
  };
  if (!detail::ResolveFilterGain(design, options, &t.filter_gain, &sum)) return finish();
  const Index n = design.A.rows();
  t.L = MatrixXd::Identity(n, n) - t.filter_gain * design.C;
  detail::NoiseInputOf(design, &t.G, &t.noise_cov);
  const MatrixXd F = t.L * design.A;
  t.filter_spectral_radius = SpectralRadius(F);
  if (t.filter_spectral_radius >= 1.0) {
    sum.termination = Termination::kUnstable;
    sum.message = "the filter is unstable (rho(L A_M) = " + std::to_string(t.filter_spectral_radius) +
                  "): no stationary error, no bound";
    return finish();
  }
  // B (25) = L G Q_M G^T L^T + K_M R_M K_M^T; i^T M^{-1} b = tr X, X = F X F^T + B.
  MatrixXd B = t.L * design.Q * t.L.transpose() + t.filter_gain * design.R * t.filter_gain.transpose() +
               DesignCrossTerm(design, t.L, t.filter_gain);
  Symmetrize(B);
  MatrixXd X, Y;
  if (!detail::SolveStein(F, B, "(25)", &X, &sum)) return finish();
  t.nominal_trace = X.trace();
  // M^T = I - F^T (x) F^T, so (M^{-1})^T i = cs(Y) with Y = F^T Y F + I.
  if (!detail::SolveStein(F.transpose(), MatrixXd::Identity(n, n), "adjoint (24)", &Y, &sum)) return finish();
  t.adjoint_norm = Y.norm();
  sum.termination = Termination::kConverged;
  return finish();
}

Theorem1Result Theorem1Bound(const ModelStep& design, const ModelingErrors& errors, const MismatchOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  if (options.input.size() > 0) {
    throw Error(
        "options.input: Theorem 1 takes no known input (its D has no mean terms); use "
        "StationaryMismatchedCovariance for the true error with an input");
  }
  const DesignTerms t = ComputeDesignTerms(design, options);
  const ModelStep truth = ApplyModelingErrors(design, errors);
  Theorem1Result r;
  Summary& sum = r.summary;
  sum.method = "(22)-(27) with the stationary (15)-(17)";
  const auto finish = [&]() {
    detail::FinishSummary("Theorem 1 bound", start, &sum);
    return std::move(r);
  };
  if (!t.summary.ok()) {
    AdoptOutcome(t.summary, &sum);
    return finish();
  }
  MismatchOptions fixed = options;
  fixed.filter_gain = t.filter_gain;
  r.exact = StationaryMismatchedCovariance(design, truth, fixed);
  if (!r.exact.summary.ok()) {
    AdoptOutcome(r.exact.summary, &sum);
    return finish();
  }
  const Index n = design.A.rows(), m = design.C.rows(), p = t.noise_cov.rows();
  const MatrixXd& K = t.filter_gain;
  const MatrixXd& L = t.L;
  const MatrixXd dA = detail::OrZeros(errors.A, n, n);
  const MatrixXd dC = detail::OrZeros(errors.C, m, n);
  const MatrixXd dQ = t.G * detail::OrZeros(errors.Q, p, p) * t.G.transpose();
  const MatrixXd dR = detail::OrZeros(errors.R, m, m);
  const MatrixXd& AM = design.A;
  const MatrixXd F = L * AM;
  const MatrixXd dCp = L * dA - K * dC * AM + K * dC * dA;  // (27)
  const MatrixXd LK = L + K * dC;
  const MatrixXd& QM = design.Q;  // G Q_M G^T
  const MatrixXd& V = r.exact.V;
  const MatrixXd& U = r.exact.U;
  // (26), corrected (docs/papers/002.md).
  MatrixXd D = L * QM * dC.transpose() * K.transpose() + K * dC * QM * LK.transpose() +
               dCp * V * AM.transpose() * L.transpose() + L * AM * V.transpose() * dCp.transpose() +
               dCp * U * dCp.transpose() - LK * dQ * LK.transpose() - K * dR * K.transpose();
  if (design.has_cross_covariance() || truth.has_cross_covariance()) {  // H + H^T, H = L S_M K^T - LK S_t K^T
    MatrixXd H = -LK * truth.S * K.transpose();
    if (design.has_cross_covariance()) H.noalias() += L * design.S * K.transpose();
    D += H + H.transpose();
  }
  Symmetrize(D);
  r.D_norm = D.norm();
  r.pi1 = t.nominal_trace + t.adjoint_norm * r.D_norm;
  MatrixXd B = L * QM * L.transpose() + K * design.R * K.transpose() + DesignCrossTerm(design, L, K);
  Symmetrize(B);
  MatrixXd X;
  if (!detail::SolveStein(F, B + D, "identity (22)", &X, &sum)) return finish();
  r.identity_trace = X.trace();
  sum.termination = Termination::kConverged;
  return finish();
}

double Theorem2Bound(const ModelStep& truth) {
  detail::ValidateDesignStep(truth, "truth: ");
  if (HasNonzeroS(truth)) {
    throw Error(
        "truth.S: Theorem 2 does not hold for a truth with a cross-covariance S (its optimal filter uses "
        "the correlation and can beat pi_2; docs/papers/002.md, Beyond 002)");
  }
  const Index n = truth.A.rows();
  const Eigen::LLT<MatrixXd> r_llt(truth.R);
  const MatrixXd CA = truth.C * truth.A;
  const MatrixXd a1_matrix = CA.transpose() * r_llt.solve(CA);  // A^T C^T R^{-1} C A (PSD)
  const double a1 = detail::SpectralNorm(a1_matrix);            // (29), exponent 1 (printed: 5)
  Eigen::VectorXcd lambda;
  if (!detail::EigenDecompose(truth.A, &lambda, nullptr))
    throw NumericalError("Theorem 2: eigenvalues of A: QR failed");
  const double a2 = static_cast<double>(n) + (truth.C.transpose() * r_llt.solve(truth.C) * truth.Q).trace() -
                    lambda.cwiseAbs2().sum();  // (30)
  const double a3 = truth.Q.trace();           // (31)
  return QuadraticLowerRoot(a1, a2, a3);
}

double Theorem3Bound(const DesignTerms& terms, const ErrorNorms& norms) {
  RequirePlantExact(norms, "Theorem 3");
  RequireComputedTerms(terms);
  const double lg = detail::SpectralNorm(terms.L * terms.G), k = detail::SpectralNorm(terms.filter_gain);
  const double s = 2.0 * detail::SpectralNorm(terms.L) * k * norms.S;  // kfx's S term: D has L dS K^T + its transpose
  return terms.nominal_trace + terms.adjoint_norm * (lg * lg * norms.Q + k * k * norms.R + s);  // (33)
}

double Theorem4Bound(const ModelStep& design, const ErrorNorms& norms, EigenvalueTerm eigenvalue_term) {
  RequirePlantExact(norms, "Theorem 4");
  detail::ValidateDesignStep(design, "design: ");
  RequireNoCrossCovariance(norms, design, "Theorem 4");
  MatrixXd G, QM;
  detail::NoiseInputOf(design, &G, &QM);
  const Index n = design.A.rows();
  const double r_min = MinEigenvalueSym(design.R) - norms.R;  // Weyl, (38)
  if (!(r_min > 0.0)) return 0.0;
  const double ca = detail::SpectralNorm(design.C * design.A);
  const double alpha1 = ca * ca / r_min;  // (35)
  double eig_term = 0.0;
  if (eigenvalue_term == EigenvalueTerm::kAsPrinted) {
    Eigen::VectorXcd lambda;
    if (!detail::EigenDecompose(design.A, &lambda, nullptr))
      throw NumericalError("Theorem 4: eigenvalues of A: QR failed");
    eig_term = lambda.cwiseAbs2().sum();
  } else {
    eig_term = design.A.trace() * design.A.trace() / static_cast<double>(std::max<Index>(n, 1));
  }
  const double alpha2 = static_cast<double>(n) +
                        (design.C * G).squaredNorm() * (detail::SpectralNorm(QM) + norms.Q) / r_min - eig_term;  // (36)
  const double g = detail::SpectralNorm(G);
  const double alpha3 =
      (G * QM * G.transpose()).trace() - static_cast<double>(G.cols()) * g * g * norms.Q;  // (37), (40)
  return QuadraticLowerRoot(alpha1, alpha2, alpha3);
}

LemmaBound LemmaStateBound(const ModelStep& design, double dA_norm) {
  detail::ValidateDesignStep(design, "design: ");
  if (!(dA_norm >= 0.0) || !std::isfinite(dA_norm)) {
    throw Error("dA_norm: expected a finite non-negative number, got " + std::to_string(dA_norm));
  }
  const auto start = std::chrono::steady_clock::now();
  LemmaBound b;
  Summary& sum = b.summary;
  sum.method = "Cayley transform (42)";
  const auto finish = [&](Termination termination, std::string message) {
    sum.termination = termination;
    sum.message = std::move(message);
    detail::FinishSummary("Lemma of Sec. 5", start, &sum);
    return std::move(b);
  };
  const Index n = design.A.rows();
  const MatrixXd& AM = design.A;
  const MatrixXd I = MatrixXd::Identity(n, n);
  Eigen::VectorXcd lambda;
  Eigen::MatrixXcd T;
  if (!detail::EigenDecompose(AM, &lambda, &T)) return finish(Termination::kFailed, "eigenvectors of A_M: QR failed");
  b.sigma = -kInf;
  for (Index k = 0; k < n; ++k) {
    if (std::abs(lambda(k) + 1.0) < 1e-12) {
      return finish(Termination::kSingular, "A_M has the eigenvalue -1: no Cayley transform (42)");
    }
    b.sigma = std::max(b.sigma, ((lambda(k) - 1.0) / (lambda(k) + 1.0)).real());  // eigenvalues of F_M
  }
  b.kappa = detail::ConditionNumber(T);
  if (!(b.sigma < 0.0)) return finish(Termination::kUnstable, "A_M is not stable (max Re lambda(F_M) >= 0)");
  if (!(b.kappa < 1e12)) {
    return finish(Termination::kUndecided,
                  "A_M is not (numerically) diagonalizable: cond(T) = " + std::to_string(b.kappa));
  }
  // F_M = (A_M^T + I)^{-1} (A_M^T - I) (42).
  const MatrixXd FM = (AM.transpose() + I).partialPivLu().solve(AM.transpose() - I);
  // U_M: F_M^T U_M + U_M F_M = -(I - F_M^T) G Q G^T (I - F_M); by (44) U_M = 2 X, X = A_M X A_M^T + G Q G^T.
  MatrixXd X;
  if (!detail::SolveStein(AM, design.Q, "U_M (44)", &X, &sum)) return finish(sum.termination, sum.message);
  b.UM_norm = 2.0 * detail::SpectralNorm(X);
  const double ifm = detail::SpectralNorm(I - FM);
  const double c = ifm * ifm * (dA_norm * dA_norm + 2.0 * dA_norm * detail::SpectralNorm(AM));
  b.x = c * b.kappa * b.kappa / (-4.0 * b.sigma);
  b.beta_printed = 0.5 * b.UM_norm * std::exp(2.0 * b.x);  // (41): exp[-kappa^2 / (2 sigma) c]
  b.beta = b.x < 1.0 ? 0.5 * b.UM_norm / (1.0 - b.x) : kInf;
  static const double limit = PrintedLemmaLimit();
  b.printed_is_valid = b.x <= limit;
  return finish(Termination::kConverged, "x = " + FormatNumber(b.x));
}

Theorem5Result Theorem5Bound(const ModelStep& design, const DesignTerms& terms, const ErrorNorms& norms) {
  RequireNoiseExact(norms, "Theorem 5");
  RequireComputedTerms(terms);
  RequireNoCrossCovariance(norms, design, "Theorem 5");
  Theorem5Result r;
  r.lemma = LemmaStateBound(design, norms.A);
  if (!r.lemma.applies()) {
    r.pi5 = r.pi5_printed = kInf;
    return r;
  }
  const MatrixXd& K = terms.filter_gain;
  const double nk = detail::SpectralNorm(K), nam = detail::SpectralNorm(design.A);
  const double d = detail::SpectralNorm(terms.L) * norms.A + nk * nam * norms.C + nk * norms.C * norms.A;  // (48)
  const double m = terms.adjoint_norm;
  const double f = detail::SpectralNorm(terms.L * design.A);
  const double extra = nk * nk * detail::SpectralNorm(design.Q) * norms.C * norms.C +
                       2.0 * nk * detail::SpectralNorm(terms.L * design.Q) * norms.C;
  auto pi5 = [&](double beta) {
    if (!std::isfinite(beta)) return kInf;
    const double mu1 = std::sqrt(beta) * m * f * d;
    const double mu2 = terms.nominal_trace + m * (beta * d * d + extra);
    const double s = mu1 + std::sqrt(mu1 * mu1 + mu2);
    return s * s;  // (46)
  };
  r.pi5 = pi5(r.lemma.beta);
  r.pi5_printed = pi5(r.lemma.beta_printed);
  return r;
}

double Theorem6Bound(const ModelStep& design, const ErrorNorms& norms) {
  RequireNoiseExact(norms, "Theorem 6");
  detail::ValidateDesignStep(design, "design: ");
  RequireNoCrossCovariance(norms, design, "Theorem 6");
  const Index n = design.A.rows();
  const double h = detail::SpectralNorm(design.C) + norms.C;
  const double r_inv = 1.0 / MinEigenvalueSym(design.R);
  const double a = detail::SpectralNorm(design.A) + norms.A;
  const double tr_q = design.Q.trace();
  const double gamma1 = h * h * r_inv * a * a;
  const double t = std::max(0.0, std::abs(design.A.trace()) - norms.A_diagonal_abs_sum);
  const double gamma2 =
      static_cast<double>(n) + h * h * r_inv * tr_q - t * t / static_cast<double>(std::max<Index>(n, 1));
  return QuadraticLowerRoot(gamma1, gamma2, tr_q);  // (50)
}

PatelTodaBounds ComputePatelTodaBounds(const ModelStep& design, const ErrorRanges& ranges,
                                       const MismatchOptions& options) {
  ValidateErrorRanges(design, ranges);
  const auto start = std::chrono::steady_clock::now();
  PatelTodaBounds b;
  b.norms = ErrorNormsFromRanges(ranges);
  b.terms = ComputeDesignTerms(design, options);
  b.summary.method = "Theorems 3-6";
  if (!b.terms.summary.ok()) {
    AdoptOutcome(b.terms.summary, &b.summary);
    detail::FinishSummary("Patel-Toda bounds", start, &b.summary);
    return b;
  }
  // Issue 22: the bounds that do not hold with the truth's S or an unmodelled input are refused, saying why.
  const bool cross = b.norms.S > 0.0 || HasNonzeroS(design);
  const char* kCrossWhy = "the truth has a cross-covariance S: ";
  const char* kInputWhy =
      "the truth has a known input the filter does not model: the error's mean (tr P includes |E x~|^2) "
      "is not bounded by the ranges";
  if (ranges.PlantExact()) {
    ErrorNorms e = b.norms;
    e.A = e.C = e.A_diagonal_abs_sum = 0.0;
    if (ranges.unmodelled_input) {
      b.refused.push_back(std::string("pi3: ") + kInputWhy);
    } else {
      b.pi3 = Theorem3Bound(b.terms, e);
    }
    if (cross) {
      b.refused.push_back(std::string("pi4: ") + kCrossWhy +
                          "its optimal filter uses the correlation and can have tr P_F below pi4");
    } else {
      b.pi4 = Theorem4Bound(design, e);
    }
  }
  if (ranges.NoiseExact()) {
    ErrorNorms e = b.norms;
    e.Q = e.R = 0.0;
    if (cross || ranges.unmodelled_input) {
      b.refused.push_back(std::string("pi5: ") +
                          (cross ? std::string(kCrossWhy) + "Theorem 5's D has no S term" : kInputWhy));
    } else {
      const Theorem5Result t5 = Theorem5Bound(design, b.terms, e);
      b.pi5 = t5.pi5;
      b.pi5_printed = t5.pi5_printed;
      b.lemma = t5.lemma;
    }
    if (cross) {
      b.refused.push_back(std::string("pi6: ") + kCrossWhy +
                          "its optimal filter uses the correlation and can have tr P_F below pi6");
    } else {
      b.pi6 = Theorem6Bound(design, e);
    }
  }
  for (const std::string& r : b.refused) b.summary.message += (b.summary.message.empty() ? "" : "; ") + r;
  b.summary.termination = Termination::kConverged;
  detail::FinishSummary("Patel-Toda bounds", start, &b.summary);
  return b;
}

}  // namespace kfx
