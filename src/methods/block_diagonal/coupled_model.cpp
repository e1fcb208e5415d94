// The coupled-subsystem model of 004 (include/kfx/block_diagonal.hpp): the shape checks of one step,
// its validation, CoupledSystem (time-invariant, a stored sequence, or a callback; the prior), the
// model's mean maps (x -> F x, H F x) and its simulation.
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "kfx/block_diagonal.hpp"
#include "kfx/error.hpp"
#include "kfx/simulation.hpp"
#include "kfx/validation.hpp"
#include "methods/block_diagonal/block_diagonal_shared.hpp"

namespace kfx {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace detail {

void RequireStepShapes(const CoupledStep& s, const std::string& label) {
  const Index c = s.F.rows();
  if (c == 0 || s.F.cols() % c != 0) {
    throw Error(label + "F: expected c x (n c) packed blocks with c >= 1, got " + ShapeString(s.F.rows(), s.F.cols()));
  }
  const Index n = s.F.cols() / c, d = s.H.rows(), r = s.G.cols();
  RequireShape(label + "H", s.H, d, n * c);
  if (d == 0) throw Error(label + "H: expected d >= 1 measurement rows per subsystem, got 0");
  RequireShape(label + "V", s.V, c, n * c);
  RequireShape(label + "R", s.R, d, n * d);
  RequireShape(label + "G", s.G, n * c, r);
  RequireShape(label + "U", s.U, r, r);
}

void RequirePackedCovariance(const std::string& name, const MatrixXd& P, Index c, Index n) {
  RequireShape(name, P, c, n * c);
}

}  // namespace detail

using detail::BlockOf;
using detail::RequirePackedCovariance;
using detail::RequireStepShapes;

CoupledStep MakeIdenticalCoupledStep(Index n, const MatrixXd& F, const MatrixXd& H, const MatrixXd& V,
                                     const MatrixXd& R, const MatrixXd& g, const MatrixXd& U) {
  if (n < 1) throw Error("n: expected at least 1 subsystem, got " + std::to_string(n));
  RequireSquare("F", F);
  const Index c = F.rows();
  RequireShape("H", H, -1, c);
  RequireShape("V", V, c, c);
  RequireShape("R", R, H.rows(), H.rows());
  RequireShape("g", g, c, -1);
  RequireShape("U", U, g.cols(), g.cols());
  CoupledStep s;
  s.F = F.replicate(1, n);
  s.H = H.replicate(1, n);
  s.V = V.replicate(1, n);
  s.R = R.replicate(1, n);
  s.G = g.replicate(n, 1);
  s.U = U;
  return s;
}

void ValidateCoupledStep(const CoupledStep& s, Index n, Index c, Index d, Index r, const std::string& label) {
  RequireShape(label + "F", s.F, c, n * c);
  RequireShape(label + "H", s.H, d, n * c);
  RequireShape(label + "V", s.V, c, n * c);
  RequireShape(label + "R", s.R, d, n * d);
  RequireShape(label + "G", s.G, n * c, r);
  RequireShape(label + "U", s.U, r, r);
  RequireFinite(label + "F", s.F);
  RequireFinite(label + "H", s.H);
  RequireFinite(label + "G", s.G);
  RequirePositiveSemidefinite(label + "U", s.U);
  for (Index i = 0; i < n; ++i) {
    const std::string b = " (block " + std::to_string(i) + ")";
    RequirePositiveSemidefinite(label + "V" + b, s.V.middleCols(i * c, c));
    RequirePositiveDefinite(label + "R" + b, s.R.middleCols(i * d, d));
  }
}

CoupledSystem::CoupledSystem(CoupledStep step, VectorXd m0, MatrixXd P0_blocks)
    : kind_(detail::ScheduleKind::kInvariant), m0_(std::move(m0)), P0_(std::move(P0_blocks)) {
  RequireStepShapes(step, "");
  n_ = step.n(), c_ = step.c(), d_ = step.d(), r_ = step.r();
  ValidateCoupledStep(step, n_, c_, d_, r_);
  steps_.push_back(std::make_shared<const CoupledStep>(std::move(step)));
  ValidatePrior();
}

CoupledSystem::CoupledSystem(std::vector<CoupledStep> steps, VectorXd m0, MatrixXd P0_blocks)
    : kind_(detail::ScheduleKind::kSequence), m0_(std::move(m0)), P0_(std::move(P0_blocks)) {
  if (steps.empty()) throw Error("steps: expected at least one step");
  RequireStepShapes(steps[0], "step 1: ");
  n_ = steps[0].n(), c_ = steps[0].c(), d_ = steps[0].d(), r_ = steps[0].r();
  for (size_t k = 0; k < steps.size(); ++k) {
    ValidateCoupledStep(steps[k], n_, c_, d_, r_, "step " + std::to_string(k + 1) + ": ");
    steps_.push_back(std::make_shared<const CoupledStep>(std::move(steps[k])));
  }
  horizon_ = static_cast<int>(steps_.size());
  ValidatePrior();
}

CoupledSystem::CoupledSystem(Index n, Index c, Index d, Index r, StepFunction function, VectorXd m0, MatrixXd P0_blocks,
                             int horizon)
    : kind_(detail::ScheduleKind::kFunction),
      n_(n),
      c_(c),
      d_(d),
      r_(r),
      horizon_(horizon),
      function_(std::move(function)),
      m0_(std::move(m0)),
      P0_(std::move(P0_blocks)) {
  if (n < 1 || c < 1 || d < 1 || r < 0) {
    throw Error("n, c, d, r: expected n, c, d >= 1 and r >= 0, got " + std::to_string(n) + ", " + std::to_string(c) +
                ", " + std::to_string(d) + ", " + std::to_string(r));
  }
  if (!function_) throw Error("function: expected a step callback");
  ValidatePrior();
}

void CoupledSystem::ValidatePrior() const {
  RequireVector("m0", m0_, n_ * c_);
  RequireFinite("m0", m0_);
  RequirePackedCovariance("P0", P0_, c_, n_);
  for (Index i = 0; i < n_; ++i) {
    RequirePositiveSemidefinite("P0 (block " + std::to_string(i) + ")", P0_.middleCols(i * c_, c_));
  }
}

std::shared_ptr<const CoupledStep> CoupledSystem::step(int k) const {
  return detail::StepAt<CoupledStep>(
      k, kind_, horizon_, steps_, function_,
      [this](const CoupledStep& s, const std::string& label) { ValidateCoupledStep(s, n_, c_, d_, r_, label); },
      "step");
}

int CoupledSystem::ResolveSteps(int steps) const {
  if (steps < 0) {
    if (horizon_ < 0) throw Error("steps: expected a number of steps (the system has no horizon)");
    return horizon_;
  }
  if (horizon_ >= 0 && steps > horizon_) {
    throw Error("steps: expected at most " + std::to_string(horizon_) + " steps (the system's horizon), got " +
                std::to_string(steps));
  }
  return steps;
}

VectorXd CoupledPropagate(const CoupledStep& s, const VectorXd& x_prev) {
  return BlockDiagonalApply(s.F, s.c(), x_prev);
}

VectorXd CoupledPredictMeasurement(const CoupledStep& s, const VectorXd& x_prev) {
  return BlockDiagonalApply(s.H, s.c(), CoupledPropagate(s, x_prev));
}

CoupledTrajectory SimulateCoupled(const CoupledSystem& system, const SimulationOptions& options) {
  const int T = system.ResolveSteps(options.steps);
  const Index n = system.n(), c = system.c(), d = system.d(), r = system.r();
  Rng rng(options.seed);
  CoupledTrajectory tr;
  tr.x.resize(T + 1, n * c);
  tr.y.resize(T, n * d);
  tr.u.resize(T, r);
  VectorXd x(n * c);
  for (Index i = 0; i < n; ++i) {
    x.segment(i * c, c) =
        system.m0().segment(i * c, c) + PsdFactor(system.P0_blocks().middleCols(i * c, c)) * rng.Normal(c);
  }
  tr.x.row(0) = x.transpose();
  for (int k = 1; k <= T; ++k) {
    const auto s = system.step(k);
    const VectorXd u = PsdFactor(s->U) * rng.Normal(r);  // empty when r = 0
    VectorXd xn = CoupledPropagate(*s, x);
    if (r > 0) xn.noalias() += s->G * u;
    VectorXd yk(n * d);
    for (Index i = 0; i < n; ++i) {
      xn.segment(i * c, c) += PsdFactor(BlockOf(s->V, i, c)) * rng.Normal(c);
    }
    yk = BlockDiagonalApply(s->H, c, xn);
    for (Index i = 0; i < n; ++i) yk.segment(i * d, d) += PsdFactor(BlockOf(s->R, i, d)) * rng.Normal(d);
    x = std::move(xn);
    tr.x.row(k) = x.transpose();
    tr.y.row(k - 1) = yk.transpose();
    tr.u.row(k - 1) = u.transpose();
  }
  return tr;
}

}  // namespace kfx
