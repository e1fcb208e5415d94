// The stationary exact-performance engine (StationaryTruth, ExactStationaryPerformance; mathematics:
// docs/exact-performance.md, section 4): the joint (x, z) Lyapunov equation block by block on the real
// Schur forms of A (once per true model) and of Phi (once per filter), or the error-coordinates equation.
#include <chrono>
#include <cmath>
#include <limits>
#include <string>

#include "core/performance_internal.hpp"
#include "kfx/error.hpp"
#include "kfx/performance.hpp"
#include "kfx/riccati.hpp"
#include "kfx/validation.hpp"
#include "riccati/riccati_internal.hpp"
#include "riccati/schur_stein.hpp"

namespace kfx {

using Eigen::MatrixXd;

struct StationaryTruth::Impl {
  explicit Impl(const Model& m) : model(m), step(m.step(1)) {}
  Model model;
  StepPtr step;
  detail::RealSchur schur;  ///< of A
  double rho = std::numeric_limits<double>::quiet_NaN();
  MatrixXd X;               ///< S^xx = A S^xx A^T + Q
  MatrixXd Sxy;             ///< (A X A^T + Q) C^T + S of the computed X (n x m): E[x y^T], exact right-hand sides
  MatrixXd CA;              ///< C A (m x n)
  MatrixXd Syy;             ///< C (A X A^T + Q) C^T + C S + S^T C^T + R (m x m): E[y y^T]
  double residual_xx2 = 0;  ///< |X - A X A^T - Q|_F^2
  Summary summary;
};

namespace {

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// The x-block: S^xx on A's Schur form, and the products of it every filter needs.
void SolveStateBlock(StationaryTruth::Impl* t) {
  const ModelStep& s = *t->step;
  Summary& sum = t->summary;
  sum.computation = "stationary state covariance";
  sum.method = "schur";
  if (!t->schur.ok()) {
    sum.termination = Termination::kFailed;
    sum.message =
        "the QR algorithm failed to compute the Schur form of A (DGEES info " + std::to_string(t->schur.info) + ")";
    return;
  }
  t->rho = t->schur.SpectralRadius();
  if (!(t->rho < 1.0)) {
    sum.termination = Termination::kUnstable;
    sum.message = "the true system is not stable: rho(A) = " + std::to_string(t->rho);
    return;
  }
  const bool ok = detail::SolveLyapunovBySchur(t->schur, s.Q, &t->X);
  MatrixXd AXAtQ = s.Q;
  detail::UpdateWithCongruence(s.A, t->X, 1.0, 1.0, &AXAtQ);
  t->residual_xx2 = (t->X - AXAtQ).squaredNorm();
  sum.relative_residual = std::sqrt(t->residual_xx2) / std::max(t->X.norm(), detail::kTiny);
  if (!ok || !t->X.allFinite()) {
    sum.termination = Termination::kFailed;
    sum.message = "the Stein equation of the true state is singular to working precision";
    t->X.resize(0, 0);
    return;
  }
  // With a cross-covariance S = E[w v^T]: E[x y^T] gains S, E[y y^T] gains C S + S^T C^T.
  t->Sxy = AXAtQ * s.C.transpose();
  if (s.has_cross_covariance()) t->Sxy += s.S;
  t->CA = s.C * s.A;
  t->Syy = s.R;
  t->Syy.noalias() += s.C * t->Sxy;
  if (s.has_cross_covariance()) t->Syy.noalias() += s.S.transpose() * s.C.transpose();
  Symmetrize(t->Syy);
  sum.termination = Termination::kConverged;
  sum.message = "real Schur form (DGEES) and the blocked Bartels-Stewart solve";
}

// The joint equation (4) by blocks: S^xz = A S^xz Phi^T + G, S^zz = Phi S^zz Phi^T + N(S^xz), with
// G = E[x y^T] K^T = ((A X A^T + Q) C^T + S) K^T and N = K E[y y^T] K^T + K C A S^xz Phi^T + its transpose,
// E[y y^T] = C (A X A^T + Q) C^T + C S + S^T C^T + R (the terms in S: issue 22, as in the time-domain
// recursion of ExactPerformance). The relative residual is that of (4) itself for the computed blocks.
void SolveJointByBlocks(const StationaryTruth::Impl& t, const LinearFilterStep& f, const detail::RealSchur& phi,
                        StationaryPerformance* out) {
  Summary& sum = out->summary;
  const ModelStep& s = *t.step;
  const MatrixXd G = t.Sxy * f.K.transpose();  // ((A X A^T + Q) C^T + S) K^T, n x nz
  MatrixXd Y, Z;
  const bool ok_y = detail::SolveSteinBySchur(t.schur, phi, G, &Y);
  const MatrixXd H = f.K * (t.CA * Y) * f.Phi.transpose();  // K C A S^xz Phi^T
  MatrixXd N = f.K * t.Syy * f.K.transpose();
  N += H;
  N += H.transpose();
  Symmetrize(N);
  const bool ok_z = detail::SolveLyapunovBySchur(phi, N, &Z);
  if (!ok_y || !ok_z || !Y.allFinite() || !Z.allFinite()) {
    sum.termination = Termination::kFailed;
    sum.message = "the joint Lyapunov equation is singular to working precision";
    return;
  }
  const MatrixXd Rxz = Y - s.A * Y * f.Phi.transpose() - G;
  MatrixXd Rzz = Z - N;
  Rzz.noalias() -= f.Phi * Z * f.Phi.transpose();
  const double res2 = t.residual_xx2 + 2.0 * Rxz.squaredNorm() + Rzz.squaredNorm();
  const double norm2 = t.X.squaredNorm() + 2.0 * Y.squaredNorm() + Z.squaredNorm();
  sum.relative_residual = std::sqrt(res2) / std::max(std::sqrt(norm2), detail::kTiny);
  out->error_cov = detail::ErrorMoment(t.X, Y, Z, f.O);
  sum.termination = Termination::kConverged;
}

// The error-coordinates equation (5) for a consistent filter; false when the filter is not consistent.
bool SolveErrorCoordinates(const ModelStep& s, const LinearFilterStep& f, double rho_a, double rho_phi,
                           StationaryPerformance* out) {
  const Eigen::Index n = s.A.rows();
  bool consistent =
      f.Phi.rows() == n && (f.O.size() == 0 || (f.O - MatrixXd::Identity(n, n)).cwiseAbs().maxCoeff() <= 1e-12);
  if (!consistent || !(rho_phi < 1.0)) return false;
  MatrixXd IKC = MatrixXd::Identity(n, n);
  IKC.noalias() -= f.K * s.C;
  const MatrixXd F = IKC * s.A;
  const double scale = std::max(1.0, F.cwiseAbs().maxCoeff());
  if (!((F - f.Phi).cwiseAbs().maxCoeff() <= 1e-10 * scale)) return false;
  MatrixXd N = IKC * s.Q * IKC.transpose() + f.K * s.R * f.K.transpose();
  if (s.has_cross_covariance()) {  // e' = (I - K C)(A e + w) - K v: the cross term -(I - K C) S K^T + transpose
    const MatrixXd cross = IKC * s.S * f.K.transpose();
    N -= cross;
    N -= cross.transpose();
  }
  Symmetrize(N);
  LyapunovOptions lyapunov;
  lyapunov.method = LyapunovMethod::kSchur;
  LyapunovSolution sol = SolveDiscreteLyapunov(F, N, lyapunov);
  Summary& sum = out->summary;
  out->method = StationaryMethod::kErrorCoordinates;
  sum.method = "error-coordinates Lyapunov equation";
  sum.message = "consistent filter, rho((I - K C) A) = " + std::to_string(rho_phi) +
                " (true system rho(A) = " + std::to_string(rho_a) + ")";
  sum.relative_residual = sol.summary.relative_residual;
  if (!sol.summary.ok()) {
    AdoptOutcome(sol.summary, &sum);
    return true;
  }
  out->error_cov = std::move(sol.X);
  Symmetrize(out->error_cov);
  sum.termination = Termination::kConverged;
  return true;
}

void CheckStationaryFilter(const Model& truth, const LinearFilter& filter,
                           const StationaryPerformanceOptions& options) {
  if (!filter.time_invariant()) throw Error("filter: expected a time-invariant filter for stationary performance");
  std::string why;
  if (!options.IsValid(&why)) throw Error("options." + why);
  detail::CheckCompatible(truth, filter);
  // A known input moves only the means of x and z, and the stationary mean depends on the input sequence
  // (docs/exact-performance.md, section 5): refused rather than reported without it.
  if (truth.input_dim() > 0) {
    throw Error(
        "truth: the stationary engine takes no known input (G, D): the error's mean depends on the input "
        "sequence; evaluate it with ExactPerformance and the input g (the error covariance is that of the model "
        "without G, D)");
  }
  detail::CheckWeight(options.weight, truth.state_dim(), "options.weight");
}

}  // namespace

StationaryTruth::StationaryTruth(const Model& truth) {
  if (!truth.time_invariant()) throw Error("truth: expected a time-invariant model for stationary performance");
  auto impl = std::make_shared<Impl>(truth);
  impl->schur = detail::ComputeRealSchur(impl->step->A);
  SolveStateBlock(impl.get());
  impl_ = std::move(impl);
}

const Model& StationaryTruth::model() const { return impl_->model; }
double StationaryTruth::spectral_radius() const { return impl_->rho; }
const MatrixXd& StationaryTruth::state_covariance() const { return impl_->X; }
const Summary& StationaryTruth::summary() const { return impl_->summary; }

StationaryPerformance ExactStationaryPerformance(const StationaryTruth& truth, const LinearFilter& filter,
                                                 const StationaryPerformanceOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const StationaryTruth::Impl& t = *truth.impl_;
  CheckStationaryFilter(t.model, filter, options);
  const LinearFilterStepPtr f = filter.step(1);
  StationaryPerformance out;
  Summary& sum = out.summary;
  sum.computation = "stationary performance";
  const detail::RealSchur phi = detail::ComputeRealSchur(f->Phi);
  if (!t.schur.ok() || !phi.ok()) {
    sum.termination = Termination::kFailed;
    sum.message = std::string("the QR algorithm failed to compute the Schur form of ") + (phi.ok() ? "A" : "Phi");
    sum.seconds = SecondsSince(start);
    return out;
  }
  const double rho_a = t.rho, rho_phi = phi.SpectralRadius();
  if (rho_a < 1.0 && rho_phi < 1.0) {
    out.method = StationaryMethod::kJoint;
    sum.method = "joint Lyapunov equation";
    sum.message = "rho(A) = " + std::to_string(rho_a) + ", rho(Phi) = " + std::to_string(rho_phi) +
                  "; by blocks on the Schur forms of A and Phi";
    if (!t.summary.ok()) {
      AdoptOutcome(t.summary, &sum);
    } else {
      SolveJointByBlocks(t, *f, phi, &out);
    }
  } else if (!SolveErrorCoordinates(*t.step, *f, rho_a, rho_phi, &out)) {
    sum.termination = Termination::kUnstable;
    sum.message = rho_phi >= 1.0
                      ? "no stationary error: the filter is unstable (rho(Phi) = " + std::to_string(rho_phi) + ")"
                      : "no stationary error: the true system is unstable (rho(A) = " + std::to_string(rho_a) +
                            ") and the filter is not consistent with it (Phi != (I - K C) A), so the "
                            "error grows with the state; use ExactPerformance over a finite horizon";
  }
  if (sum.ok()) {
    out.mse = out.error_cov.trace();
    out.weighted_mse = detail::WeightedTrace(options.weight, out.error_cov);
  } else if (sum.termination != Termination::kUnstable) {
    out.error_cov.resize(0, 0);
  }
  sum.seconds = SecondsSince(start);
  return out;
}

StationaryPerformance ExactStationaryPerformance(const Model& truth, const LinearFilter& filter,
                                                 const StationaryPerformanceOptions& options) {
  if (!truth.time_invariant()) throw Error("truth: expected a time-invariant model for stationary performance");
  CheckStationaryFilter(truth, filter, options);
  return ExactStationaryPerformance(StationaryTruth(truth), filter, options);
}

}  // namespace kfx
