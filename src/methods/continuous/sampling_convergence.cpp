// Convergence of the sampled filter to the Kalman-Bucy filter (paper 003): err(n), the bounds of
// Theorems 1-4 / Corollary 1, and the modal wave model of Example 1. See
// include/kfx/sampling_convergence.hpp and docs/papers/003.md.
#include "kfx/sampling_convergence.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "kfx/discretize.hpp"
#include "kfx/error.hpp"
#include "kfx/validation.hpp"

namespace kfx {

namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

double SpectralNorm(const MatrixXd& M) {
  if (M.size() == 0) return 0.0;
  return Eigen::JacobiSVD<MatrixXd>(M).singularValues()(0);
}

double MinEig(const MatrixXd& S) { return Eigen::SelfAdjointEigenSolver<MatrixXd>(S).eigenvalues()(0); }

// sup_{t in [0, T]} |e^{A t}|: a grid of 2048 steps, then golden-section search on the cell
// around the grid maximum.
double SemigroupBound(const MatrixXd& A, double T) {
  const int grid = 2048;
  const double dt = T / grid;
  const MatrixXd step = MatrixExponential(A * dt);
  MatrixXd E = MatrixXd::Identity(A.rows(), A.cols());
  double best = 1.0;
  int best_i = 0;
  for (int i = 1; i <= grid; ++i) {
    E = E * step;
    const double v = SpectralNorm(E);
    if (v > best) {
      best = v;
      best_i = i;
    }
  }
  auto f = [&](double t) { return SpectralNorm(MatrixExponential(A * t)); };
  double lo = std::max(0.0, (best_i - 1) * dt), hi = std::min(T, (best_i + 1) * dt);
  const double g = 0.5 * (std::sqrt(5.0) - 1.0);
  double a = hi - g * (hi - lo), b = lo + g * (hi - lo);
  double fa = f(a), fb = f(b);
  for (int it = 0; it < 40; ++it) {
    if (fa > fb) {
      hi = b;
      b = a;
      fb = fa;
      a = hi - g * (hi - lo);
      fa = f(a);
    } else {
      lo = a;
      a = b;
      fa = fb;
      b = lo + g * (hi - lo);
      fb = f(b);
    }
  }
  return std::max({best, fa, fb, f(T)});
}

}  // namespace

BoundConstants ComputeBoundConstants(const ContinuousModel& model, double T) {
  ValidateContinuousModel(model);
  if (!(std::isfinite(T) && T > 0.0)) throw Error("T: expected a finite value > 0, got " + std::to_string(T));
  BoundConstants c;
  const MatrixXd G = model.ProcessNoise();
  c.mu = SemigroupBound(model.A, T);
  c.norm_A = SpectralNorm(model.A);
  c.norm_C = SpectralNorm(model.C);
  c.min_eig_R = MinEig(model.R);
  c.tr_P0 = model.P0.trace();
  c.tr_BQB = G.trace();
  c.tr_ABQBA = (model.A * G * model.A.transpose()).trace();
  c.tr_AP0A = (model.A * model.P0 * model.A.transpose()).trace();
  MatrixXd graph(2 * model.state_dim(), model.state_dim());
  graph << model.P0, model.A * model.P0;
  c.norm_P0_graph = SpectralNorm(graph);
  c.r = static_cast<int>(model.output_dim());
  return c;
}

SamplingBounds EvaluateSamplingBounds(const BoundConstants& c, double T, int n, double E) {
  SamplingBounds b;
  const double nn = static_cast<double>(n);
  const double mu2 = c.mu * c.mu, C2 = c.norm_C * c.norm_C, A2 = c.norm_A * c.norm_A;
  const double lam = c.min_eig_R;
  const double M = mu2 * c.tr_P0 * E * C2 * A2 / (12.0 * lam);  // Theorem 1 (= M2 of Theorem 2)
  b.theorem1 = M * std::pow(T, 3) / (nn * nn);
  const double M1 = C2 * c.tr_BQB * E / lam;
  const double M3 = mu2 * C2 * c.tr_ABQBA * E / (2.0 * lam);
  b.theorem2 = M1 * T * T / nn + M * std::pow(T, 3) / (nn * nn) + M3 * std::pow(T, 4) / (nn * nn);
  b.theorem2_proof = M1 * T * T / (2.0 * nn) + M * std::pow(T, 3) / (nn * nn) + 0.5 * M3 * std::pow(T, 4) / (nn * nn);
  b.theorem3 = c.r * mu2 * c.norm_P0_graph * C2 * E * T * T / (2.0 * lam * nn);
  b.theorem4 = mu2 * c.tr_AP0A * C2 * E * std::pow(T, 3) / (12.0 * lam * nn * nn);
  b.corollary1 = M1 * T * T / nn + M3 * std::pow(T, 4) / (nn * nn) + b.theorem4;
  return b;
}

double LogLogSlope(const std::vector<double>& x, const std::vector<double>& y, double x_min) {
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  int k = 0;
  for (std::size_t i = 0; i < x.size() && i < y.size(); ++i) {
    if (x[i] < x_min || !(y[i] > 0.0) || !(x[i] > 0.0)) continue;
    const double lx = std::log(x[i]), ly = std::log(y[i]);
    sx += lx;
    sy += ly;
    sxx += lx * lx;
    sxy += lx * ly;
    ++k;
  }
  if (k < 2) return std::numeric_limits<double>::quiet_NaN();
  const double den = k * sxx - sx * sx;
  if (den == 0.0) return std::numeric_limits<double>::quiet_NaN();
  return (k * sxy - sx * sy) / den;
}

ConvergenceStudy StudyConvergence(const ContinuousModel& model, double T, const ConvergenceStudyOptions& options) {
  ValidateContinuousModel(model);
  if (!(std::isfinite(T) && T > 0.0)) throw Error("T: expected a finite value > 0, got " + std::to_string(T));
  if (options.n_values.empty()) throw Error("n_values: expected at least one n");
  for (int n : options.n_values)
    if (n < 1) throw Error("n_values: expected every n >= 1, got " + std::to_string(n));
  ConvergenceStudy study;
  study.constants = ComputeBoundConstants(model, T);
  study.tr_Pc = KalmanBucyCovariance(model, T).trace();
  std::vector<double> xs, ys;
  long done = 0;
  for (int n : options.n_values) {
    ConvergencePoint pt;
    pt.n = n;
    pt.tr_P = SampledFilterCovariance(model, T, n).trace();
    pt.err = pt.tr_P - study.tr_Pc;
    pt.bounds = EvaluateSamplingBounds(study.constants, T, n, pt.tr_P);
    study.points.push_back(pt);
    xs.push_back(n);
    ys.push_back(pt.err);
    if (options.progress) options.progress(++done, static_cast<long>(options.n_values.size()));
  }
  study.rate = LogLogSlope(xs, ys, options.rate_min_n);
  return study;
}

ContinuousModel WaveModalModel(const std::vector<double>& sigma2, const std::vector<double>& d, double R) {
  if (sigma2.empty() || sigma2.size() != d.size()) {
    throw Error("sigma2, d: expected the same number (>= 1) of modes, got " + std::to_string(sigma2.size()) + " and " +
                std::to_string(d.size()));
  }
  const int K = static_cast<int>(sigma2.size());
  ContinuousModel m;
  m.A = MatrixXd::Zero(2 * K, 2 * K);
  m.C = MatrixXd::Zero(1, 2 * K);
  m.P0 = MatrixXd::Zero(2 * K, 2 * K);
  for (int k = 0; k < K; ++k) {
    const double omega = std::ldexp(M_PI, k + 1);
    m.A(2 * k, 2 * k + 1) = omega;
    m.A(2 * k + 1, 2 * k) = -omega;
    m.C(0, 2 * k) = d[static_cast<std::size_t>(k)];
    m.P0(2 * k + 1, 2 * k + 1) = sigma2[static_cast<std::size_t>(k)];
  }
  m.B = MatrixXd::Zero(2 * K, 0);
  m.Q = MatrixXd::Zero(0, 0);
  m.R = MatrixXd::Constant(1, 1, R);
  m.m0 = VectorXd::Zero(2 * K);
  ValidateContinuousModel(m);
  return m;
}

}  // namespace kfx
