// Continuous-time model, exact sampling with integrated observations, Kalman-Bucy by Hamiltonian
// exponential + doubling, and the filter CARE (paper 003). Mathematics: include/kfx/continuous.hpp,
// docs/papers/003.md.
#include "kfx/continuous.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "kfx/discretize.hpp"
#include "kfx/error.hpp"
#include "kfx/kalman_filter.hpp"
#include "kfx/simulation.hpp"
#include "kfx/validation.hpp"

namespace kfx {

namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

void RequirePositiveFinite(const std::string& name, double v) {
  if (!(std::isfinite(v) && v > 0.0)) throw Error(name + ": expected a finite value > 0, got " + std::to_string(v));
}

MatrixXd BlockDiag(const MatrixXd& a, const MatrixXd& b) {
  MatrixXd out = MatrixXd::Zero(a.rows() + b.rows(), a.cols() + b.cols());
  out.topLeftCorner(a.rows(), a.cols()) = a;
  out.bottomRightCorner(b.rows(), b.cols()) = b;
  return out;
}

// One step of the augmented sampled model for a step h.
ModelStep AugmentedStep(const ContinuousModel& m, const MatrixXd& Qc, double h) {
  const Index p = m.state_dim(), r = m.output_dim();
  const IntegratedDiscretization d = DiscretizeIntegrated(m.A, Qc, h);
  MatrixXd A = MatrixXd::Zero(2 * p, 2 * p);
  A.topLeftCorner(p, p) = d.Phi;
  A.bottomLeftCorner(p, p) = d.Gamma;
  MatrixXd Q(2 * p, 2 * p);
  Q << d.Qzz, d.Qzi, d.Qzi.transpose(), d.Qii;
  Symmetrize(Q);
  MatrixXd C = MatrixXd::Zero(r, 2 * p);
  C.rightCols(p) = m.C;
  MatrixXd R = h * m.R;
  return MakeStep(std::move(A), std::move(C), std::move(Q), std::move(R));
}

VectorXd AugmentedMean(const ContinuousModel& m) {
  VectorXd x = VectorXd::Zero(2 * m.state_dim());
  x.head(m.state_dim()) = m.m0;
  return x;
}

MatrixXd AugmentedPrior(const ContinuousModel& m) {
  return BlockDiag(m.P0, MatrixXd::Zero(m.state_dim(), m.state_dim()));
}

void RequireTimes(const std::vector<double>& times) {
  if (times.empty()) throw Error("times: expected at least one sample time");
  double prev = 0.0;
  for (std::size_t i = 0; i < times.size(); ++i) {
    if (!std::isfinite(times[i]) || !(times[i] > prev)) {
      throw Error("times: expected finite, strictly increasing values > 0; times[" + std::to_string(i) +
                  "] = " + std::to_string(times[i]) + " after " + std::to_string(prev));
    }
    prev = times[i];
  }
}

MatrixXd HamiltonianExp(const ContinuousModel& m, double h) {
  const Index p = m.state_dim();
  const MatrixXd S = m.C.transpose() * m.R.llt().solve(m.C);
  MatrixXd H(2 * p, 2 * p);
  H << -m.A.transpose(), S, m.ProcessNoise(), m.A;
  return MatrixExponential(H * h);
}

}  // namespace

MatrixXd ContinuousModel::ProcessNoise() const {
  if (B.size() == 0) return MatrixXd::Zero(A.rows(), A.rows());
  MatrixXd G = B * Q * B.transpose();
  Symmetrize(G);
  return G;
}

void ValidateContinuousModel(const ContinuousModel& m) {
  RequireSquare("A", m.A);
  RequireFinite("A", m.A);
  const Index p = m.A.rows();
  if (p == 0) throw Error("A: expected at least one state (got 0 x 0)");
  // No input noise: B and Q both empty (any 0-size shape), or B with zero columns.
  if (m.B.size() > 0 || m.Q.size() > 0) {
    RequireShape("B", m.B, p, m.B.cols());
    RequireFinite("B", m.B);
    RequireShape("Q", m.Q, m.B.cols(), m.B.cols());
    RequirePositiveSemidefinite("Q", m.Q);
  }
  if (m.C.rows() == 0) throw Error("C: expected at least one output row");
  RequireShape("C", m.C, m.C.rows(), p);
  RequireFinite("C", m.C);
  RequireShape("R", m.R, m.C.rows(), m.C.rows());
  RequirePositiveDefinite("R", m.R);
  RequireVector("m0", m.m0, p);
  RequireShape("P0", m.P0, p, p);
  RequirePositiveSemidefinite("P0", m.P0);
}

IntegratedDiscretization DiscretizeIntegrated(const MatrixXd& A, const MatrixXd& Qc, double h) {
  RequireSquare("A", A);
  const Index p = A.rows();
  RequireShape("Qc", Qc, p, p);
  MatrixXd F = MatrixXd::Zero(2 * p, 2 * p);
  F.topLeftCorner(p, p) = A;
  F.bottomLeftCorner(p, p).setIdentity();
  const NoiseDiscretization d = DiscretizeProcessNoise(F, BlockDiag(Qc, MatrixXd::Zero(p, p)), h);
  IntegratedDiscretization out;
  out.Phi = d.Ad.topLeftCorner(p, p);
  out.Gamma = d.Ad.bottomLeftCorner(p, p);
  out.Qzz = d.Qd.topLeftCorner(p, p);
  out.Qzi = d.Qd.topRightCorner(p, p);
  out.Qii = d.Qd.bottomRightCorner(p, p);
  return out;
}

std::vector<double> UniformTimes(double T, int n) {
  RequirePositiveFinite("T", T);
  if (n < 1) throw Error("n: expected at least one sample, got " + std::to_string(n));
  std::vector<double> t(static_cast<std::size_t>(n));
  for (int i = 1; i <= n; ++i) t[static_cast<std::size_t>(i - 1)] = T * i / n;
  return t;
}

Model SampledModel(const ContinuousModel& model, const std::vector<double>& times) {
  ValidateContinuousModel(model);
  RequireTimes(times);
  const MatrixXd Qc = model.ProcessNoise();
  std::vector<ModelStep> steps;
  steps.reserve(times.size());
  double prev = 0.0;
  for (double t : times) {
    steps.push_back(AugmentedStep(model, Qc, t - prev));
    prev = t;
  }
  return Model(std::move(steps), AugmentedMean(model), AugmentedPrior(model));
}

Model SampledModel(const ContinuousModel& model, double T, int n) {
  ValidateContinuousModel(model);
  RequirePositiveFinite("T", T);
  if (n < 1) throw Error("n: expected at least one sample, got " + std::to_string(n));
  const ModelStep step = AugmentedStep(model, model.ProcessNoise(), T / n);
  const Index p = model.state_dim(), r = model.output_dim();
  auto shared = std::make_shared<const ModelStep>(step);
  return Model(
      2 * p, r, [shared](int) { return *shared; }, AugmentedMean(model), AugmentedPrior(model), n);
}

namespace {

MatrixXd FinalZBlock(const Model& sampled, int n, Index p) {
  const KalmanSchedule s = ComputeKalmanSchedule(sampled, KalmanScheduleOptions{n});
  return s.P_filt[static_cast<std::size_t>(n)].topLeftCorner(p, p);
}

}  // namespace

MatrixXd SampledFilterCovariance(const ContinuousModel& model, const std::vector<double>& times) {
  return FinalZBlock(SampledModel(model, times), static_cast<int>(times.size()), model.state_dim());
}

MatrixXd SampledFilterCovariance(const ContinuousModel& model, double T, int n) {
  return FinalZBlock(SampledModel(model, T, n), n, model.state_dim());
}

// ------------------------------------------------------------------------------------------------
// Riccati flow as a linear-fractional map.

MatrixXd RiccatiFlow::Apply(const MatrixXd& P) const {
  const Index p = P.rows();
  // X = P (I + Gamma P)^{-1}  <=>  (I + Gamma P)^T X^T = P.
  const MatrixXd M = MatrixXd::Identity(p, p) + Gamma * P;
  const MatrixXd X = M.transpose().partialPivLu().solve(P).transpose();
  MatrixXd out = Delta + Phi * X * Phi.transpose();
  Symmetrize(out);
  return out;
}

RiccatiFlow ComposeRiccatiFlows(const RiccatiFlow& first, const RiccatiFlow& second) {
  const Index p = first.Phi.rows();
  const MatrixXd I = MatrixXd::Identity(p, p);
  // W = (I + Delta1 Gamma2)^{-1}; (I + Gamma2 Delta1)^{-1} = W^T.
  const Eigen::PartialPivLU<MatrixXd> lu(I + first.Delta * second.Gamma);
  RiccatiFlow out;
  out.h = first.h + second.h;
  out.Phi = second.Phi * lu.solve(first.Phi);
  out.Gamma = first.Gamma + first.Phi.transpose() * second.Gamma * lu.solve(first.Phi);
  const MatrixXd DW = lu.solve(first.Delta);  // (I + Delta1 Gamma2)^{-1} Delta1 = Delta1 (I + Gamma2 Delta1)^{-1}
  out.Delta = second.Delta + second.Phi * DW * second.Phi.transpose();
  Symmetrize(out.Gamma);
  Symmetrize(out.Delta);
  return out;
}

RiccatiFlow KalmanBucyFlow(const ContinuousModel& model, double h) {
  ValidateContinuousModel(model);
  RequirePositiveFinite("h", h);
  const Index p = model.state_dim();
  // Scale so that the Hamiltonian step is small (well-conditioned E11).
  const MatrixXd S = model.C.transpose() * model.R.llt().solve(model.C);
  const double norm = std::max({model.A.cwiseAbs().colwise().sum().maxCoeff(), S.cwiseAbs().colwise().sum().maxCoeff(),
                                model.ProcessNoise().cwiseAbs().colwise().sum().maxCoeff()});
  int k = 0;
  while (k < 60 && 2.0 * norm * h / std::ldexp(1.0, k) > 0.5) ++k;
  const double h0 = std::ldexp(h, -k);
  const MatrixXd E = HamiltonianExp(model, h0);
  const MatrixXd E11 = E.topLeftCorner(p, p), E12 = E.topRightCorner(p, p);
  const MatrixXd E21 = E.bottomLeftCorner(p, p), E22 = E.bottomRightCorner(p, p);
  const Eigen::PartialPivLU<MatrixXd> lu(E11);
  RiccatiFlow f;
  f.h = h0;
  f.Gamma = lu.solve(E12);
  f.Delta = E11.transpose().partialPivLu().solve(E21.transpose()).transpose();  // E21 E11^{-1}
  // Phi = E22 - E21 E11^{-1} E12 (= E11^{-T} by the symplectic structure).
  f.Phi = E22 - f.Delta * E12;
  Symmetrize(f.Gamma);
  Symmetrize(f.Delta);
  for (int i = 0; i < k; ++i) f = ComposeRiccatiFlows(f, f);
  f.h = h;
  return f;
}

MatrixXd KalmanBucyCovariance(const ContinuousModel& model, double T) {
  ValidateContinuousModel(model);
  if (!(std::isfinite(T) && T >= 0.0)) throw Error("T: expected a finite value >= 0, got " + std::to_string(T));
  if (T == 0.0) return model.P0;
  return KalmanBucyFlow(model, T).Apply(model.P0);
}

// ------------------------------------------------------------------------------------------------
// CARE: the riccati layer's SolveFilterCare on (A, C, B Q B^T, R).

CareSolution SolveFilterCare(const ContinuousModel& model) {
  ValidateContinuousModel(model);
  const MatrixXd none(0, 0);
  return SolveFilterCare(model.A, model.C, model.ProcessNoise(), model.R, none, none);
}

// ------------------------------------------------------------------------------------------------
// Data: exact simulation, sampled filter, Kalman-Bucy on the interpolated path.

ContinuousTrajectory SimulateContinuous(const ContinuousModel& model, double T, int N, std::uint64_t seed) {
  const Model sampled = SampledModel(model, T, N);
  const Trajectory tr = Simulate(sampled, SimulationOptions{N, seed});
  const Index p = model.state_dim();
  ContinuousTrajectory out;
  out.t.resize(static_cast<std::size_t>(N) + 1);
  for (int i = 0; i <= N; ++i) out.t[static_cast<std::size_t>(i)] = T * i / N;
  out.z = tr.x.leftCols(p);
  out.dy = tr.y;
  return out;
}

VectorXd SampledFilterEstimate(const ContinuousModel& model, double T, const TimeSeries& dy) {
  const int n = static_cast<int>(dy.rows());
  const Model sampled = SampledModel(model, T, n);
  RequireShape("dy", dy, n, model.output_dim());
  FilterRunOptions options;
  options.store_covariances = false;
  const FilterRun run = RunFilter(sampled, dy, options);
  return run.x_filt.row(n).head(model.state_dim()).transpose();
}

KalmanBucyRun RunKalmanBucy(const ContinuousModel& model, double T, const TimeSeries& dy, int substeps) {
  ValidateContinuousModel(model);
  RequirePositiveFinite("T", T);
  const int N = static_cast<int>(dy.rows());
  if (N < 1) throw Error("dy: expected at least one increment");
  RequireShape("dy", dy, N, model.output_dim());
  RequireFinite("dy", dy);
  if (substeps < 1) throw Error("substeps: expected >= 1, got " + std::to_string(substeps));
  const double h = T / N, hs = h / substeps;
  const RiccatiFlow half = KalmanBucyFlow(model, hs / 2);
  const MatrixXd RinvC = model.R.llt().solve(model.C);  // R^{-1} C
  MatrixXd P = model.P0;
  VectorXd z = model.m0;
  auto rhs = [&](const VectorXd& zz, const MatrixXd& PP, const VectorXd& g) {
    return VectorXd(model.A * zz + PP * (RinvC.transpose() * (g - model.C * zz)).eval());
  };
  // K = P C^T R^{-1}: P * (R^{-1} C)^T.
  for (int i = 0; i < N; ++i) {
    const VectorXd g = dy.row(i).transpose() / h;
    for (int s = 0; s < substeps; ++s) {
      const MatrixXd Pm = half.Apply(P);
      const MatrixXd Pe = half.Apply(Pm);
      const VectorXd k1 = rhs(z, P, g);
      const VectorXd k2 = rhs(z + 0.5 * hs * k1, Pm, g);
      const VectorXd k3 = rhs(z + 0.5 * hs * k2, Pm, g);
      const VectorXd k4 = rhs(z + hs * k3, Pe, g);
      z += hs / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
      P = Pe;
    }
  }
  return {z, P};
}

}  // namespace kfx
