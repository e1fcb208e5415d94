// The coupled-subsystem filters of 004 on data: CoupledFilter (the online step of the block-diagonal,
// naive, banded and full filters), running one over a measurement series, and one as a LinearFilter
// (its gains and closed-loop maps). The O(n r^2) step itself is in block_diagonal_step.cpp and
// block_diagonal_passes.cpp, the model and its simulation in coupled_model.cpp, the naive, banded and
// full steps in reference_steps.cpp.
#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "base/stagnation.hpp"
#include "kfx/block_diagonal.hpp"
#include "kfx/error.hpp"
#include "kfx/validation.hpp"
#include "methods/block_diagonal/block_diagonal_internal.hpp"
#include "methods/block_diagonal/block_diagonal_shared.hpp"

namespace kfx {

using detail::BlockDiagonalUpdate;
using detail::EstimateFold;
using detail::RequirePackedCovariance;
using detail::RequireStepShapes;
using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

const char* ToString(CoupledFilterKind kind) {
  switch (kind) {
    case CoupledFilterKind::kBlockDiagonal:
      return "block-diagonal";
    case CoupledFilterKind::kBlockDiagonalNaive:
      return "block-diagonal-naive";
    case CoupledFilterKind::kBanded:
      return "banded";
    case CoupledFilterKind::kFull:
      return "full";
  }
  return "?";
}

CoupledFilter::CoupledFilter(CoupledFilterKind kind, VectorXd x0, const MatrixXd& P0_blocks)
    : kind_(kind), c_(P0_blocks.rows()), x_(std::move(x0)) {
  if (c_ < 1 || P0_blocks.cols() % c_ != 0) {
    throw Error("P0: expected c x (n c) packed blocks, got " + ShapeString(P0_blocks.rows(), P0_blocks.cols()));
  }
  RequireVector("x0", x_, P0_blocks.cols());
  RequireFinite("x0", x_);
  RequireFinite("P0", P0_blocks);
  P_ = kind == CoupledFilterKind::kFull ? BlockDiagonalToDense(P0_blocks, c_) : P0_blocks;
}

bool MaskMissingMeasurements(const CoupledStep& s, const VectorXd& y, CoupledStep* masked, VectorXd* y_masked) {
  const Index n = s.n(), c = s.c(), d = s.d();
  if (y.size() != n * d) {  // (not RequireVector: it rejects NaN)
    throw Error("y: expected a vector of length " + std::to_string(n * d) + " (n d), got length " +
                std::to_string(y.size()));
  }
  if (y.array().isInf().any()) throw Error("y: expected finite values or NaN (a missing measurement), got inf");
  if (!y.array().isNaN().any()) return false;
  *masked = s;
  *y_masked = y;
  for (Index i = 0; i < n; ++i) {
    for (Index j = 0; j < d; ++j) {
      if (!std::isnan(y(i * d + j))) continue;
      (*y_masked)(i * d + j) = 0.0;
      masked->H.block(j, i * c, 1, c).setZero();
      const double variance = s.R(j, i * d + j);
      masked->R.block(j, i * d, 1, d).setZero();
      masked->R.block(0, i * d + j, d, 1).setZero();
      masked->R(j, i * d + j) = variance;
    }
  }
  return true;
}

void CoupledFilter::Step(const CoupledStep& step, const VectorXd& measured) {
  CoupledStep masked_step;
  VectorXd masked_y;
  const bool missing = MaskMissingMeasurements(step, measured, &masked_step, &masked_y);
  const CoupledStep& s = missing ? masked_step : step;
  const VectorXd& y = missing ? masked_y : measured;
  CheckStep(s);
  if (kind_ == CoupledFilterKind::kBlockDiagonal) {
    // The prediction and the innovation are formed inside pass 1, chunk by chunk, while F and H are
    // in cache: at large n the step streams its arrays from memory once less.
    RequirePackedCovariance("P", P_, s.c(), s.n());
    x_next_.resize(x_.size());
    nu_.resize(y.size());
    const detail::PredictFold predict{x_.data(), y.data(), x_next_.data(), nu_.data()};
    const EstimateFold fold{nu_.data(), x_next_.data(), &mu_u_, &predict};
    BlockDiagonalUpdate(s, P_, work_, /*store_gain=*/false, &fold);
    sigma_u_ = work_.gain.C1;
    P_.swap(work_.P_filt);
    x_.swap(x_next_);
    return;
  }
  VectorXd x_pred = CoupledPropagate(s, x_);
  const VectorXd nu = y - BlockDiagonalApply(s.H, s.c(), x_pred);
  Update(s, nu, std::move(x_pred));
}

void CoupledFilter::CheckStep(const CoupledStep& s) const {
  RequireStepShapes(s, "");
  if (s.c() != c_ || s.n() * s.c() != x_.size()) {
    throw Error("step: expected " + std::to_string(x_.size() / c_) + " subsystems of " + std::to_string(c_) +
                " states, got " + std::to_string(s.n()) + " of " + std::to_string(s.c()));
  }
}

void CoupledFilter::StepWithInnovation(const CoupledStep& s, const VectorXd& nu) {
  CheckStep(s);
  RequireVector("innovation", nu, s.n() * s.d());
  Update(s, nu, CoupledPropagate(s, x_));
}

void CoupledFilter::Update(const CoupledStep& s, const VectorXd& nu, VectorXd x) {
  switch (kind_) {
    case CoupledFilterKind::kBlockDiagonal: {
      // The covariance passes apply the gain as they go (no separate passes over E and Y for K nu and
      // mu_u; work_'s buffers are reused from step to step). The gain is not stored: the passes never
      // read it (they apply E = A G from G in place), so writing E^T, Y^T would only cost bandwidth.
      RequirePackedCovariance("P", P_, s.c(), s.n());
      const EstimateFold fold{nu.data(), x.data(), &mu_u_, nullptr};
      BlockDiagonalUpdate(s, P_, work_, /*store_gain=*/false, &fold);
      sigma_u_ = work_.gain.C1;
      P_.swap(work_.P_filt);
      break;
    }
    case CoupledFilterKind::kBlockDiagonalNaive: {
      DenseGainCovarianceStep st = NaiveBlockDiagonalCovarianceUpdate(s, P_);
      x += st.K * nu;
      // The posterior of u from the same quantities as the fast form (eq. after (17)).
      const BlockDiagonalCovarianceStep fast = BlockDiagonalCovarianceUpdate(s, P_);
      mu_u_ = fast.gain.CouplingMean(nu);
      sigma_u_ = fast.gain.C1;
      P_ = std::move(st.P_filt);
      break;
    }
    case CoupledFilterKind::kBanded: {
      BandedCovarianceStep st = BandedCovarianceUpdate(s, P_);
      x += BlockDiagonalApply(st.K, s.d(), nu);
      P_ = std::move(st.P_filt);
      break;
    }
    case CoupledFilterKind::kFull: {
      FullCovarianceStep st = FullCovarianceUpdate(s, P_);
      x += st.Apply(nu);
      P_ = std::move(st.P_filt);
      break;
    }
  }
  x_ = std::move(x);
}

CoupledRun RunCoupledFilter(const CoupledSystem& system, CoupledFilterKind kind, const TimeSeries& y,
                            const CoupledFilterOptions& options) {
  if (y.cols() != system.meas_dim()) {
    throw Error("y: expected " + std::to_string(system.meas_dim()) + " columns (n d), got " + std::to_string(y.cols()));
  }
  const double tol = options.steady_state_tolerance;
  if (!(tol >= 0.0 && tol <= 1e-2)) {
    throw Error("options.steady_state_tolerance: expected a value in [0, 1e-2], got " + std::to_string(tol));
  }
  const int rows = static_cast<int>(y.rows());
  const int T = system.ResolveSteps(options.steps < 0 ? rows : std::min(options.steps, rows));
  CoupledFilter filter(kind, system.m0(), system.P0_blocks());
  CoupledRun run;
  run.x_filt.resize(T + 1, system.state_dim());
  run.x_filt.row(0) = system.m0().transpose();
  const bool coupling = kind == CoupledFilterKind::kBlockDiagonal || kind == CoupledFilterKind::kBlockDiagonalNaive;
  if (coupling) run.coupling.resize(T, system.r());
  run.trace.resize(T + 1);
  auto trace = [&](const MatrixXd& P) {
    if (kind == CoupledFilterKind::kFull) return P.trace();
    double t = 0;
    for (Index i = 0; i < P.cols() / system.c(); ++i) t += P.middleCols(i * system.c(), system.c()).trace();
    return t;
  };
  run.trace(0) = trace(filter.P());
  // The steady state (options.steady_state_tolerance): the switch of RunFilter's fast path, then groups
  // of steps on the frozen gain (steady_state_run.cpp) until a row of y with a missing value.
  const bool steady = tol > 0 && kind == CoupledFilterKind::kBlockDiagonal && system.time_invariant();
  detail::SteadyStateSwitch steady_switch(tol);
  std::unique_ptr<detail::FrozenBlockDiagonal> frozen;
  MatrixXd P_prev;
  for (int k = 1; k <= T;) {
    if (frozen) {
      int L = 0;
      while (L < CoupledFilterOptions::kSteadyStateGroup && k + L <= T && y.row(k + L - 1).allFinite()) ++L;
      if (L == 0) {  // a missing value (or inf, which Step rejects): the running filter resumes from here
        filter = CoupledFilter(kind, run.x_filt.row(k - 1).transpose(), filter.P());
        frozen.reset();
        continue;
      }
      frozen->Run(y, k - 1, L, &run.x_filt, &run.coupling);
      run.trace.segment(k, L).setConstant(run.trace(k - 1));
      run.steady_state_steps += L;
      k += L;
      if (options.progress) options.progress(k - 1, T);
      continue;
    }
    if (steady) P_prev = filter.P();
    filter.Step(*system.step(k), y.row(k - 1).transpose());
    run.x_filt.row(k) = filter.x().transpose();
    if (coupling) run.coupling.row(k - 1) = filter.coupling_mean().transpose();
    run.trace(k) = trace(filter.P());
    if (steady) {
      if (!y.row(k - 1).allFinite()) {
        steady_switch.Reset();
      } else if (steady_switch.Observe((filter.P() - P_prev).norm(), filter.P().norm())) {
        frozen = std::make_unique<detail::FrozenBlockDiagonal>(*system.step(k), filter.P(),
                                                               CoupledFilterOptions::kSteadyStateGroup);
        steady_switch.Reset();
      }
    }
    if (options.progress) options.progress(k, T);
    ++k;
  }
  run.P_filt = filter.P();
  if (coupling) run.coupling_cov = frozen ? frozen->coupling_cov() : filter.coupling_cov();
  return run;
}

LinearFilter CoupledFilterAsLinearFilter(const CoupledSystem& system, CoupledFilterKind kind,
                                         const CoupledFilterOptions& options) {
  const int T = system.ResolveSteps(options.steps);
  std::vector<LinearFilterStep> out;
  out.reserve(static_cast<size_t>(T));
  MatrixXd P =
      kind == CoupledFilterKind::kFull ? BlockDiagonalToDense(system.P0_blocks(), system.c()) : system.P0_blocks();
  for (int k = 1; k <= T; ++k) {
    const auto s = system.step(k);
    MatrixXd K;
    switch (kind) {
      case CoupledFilterKind::kBlockDiagonal: {
        auto st = BlockDiagonalCovarianceUpdate(*s, P);
        K = st.gain.ToDense();
        P = std::move(st.P_filt);
        break;
      }
      case CoupledFilterKind::kBlockDiagonalNaive: {
        auto st = NaiveBlockDiagonalCovarianceUpdate(*s, P);
        K = std::move(st.K);
        P = std::move(st.P_filt);
        break;
      }
      case CoupledFilterKind::kBanded: {
        auto st = BandedCovarianceUpdate(*s, P);
        K = BlockDiagonalToDense(st.K, s->d());
        P = std::move(st.P_filt);
        break;
      }
      case CoupledFilterKind::kFull: {
        auto st = FullCovarianceUpdate(*s, P);
        K = st.ToDense();
        P = std::move(st.P_filt);
        break;
      }
    }
    const MatrixXd F = BlockDiagonalToDense(s->F, s->c()), H = BlockDiagonalToDense(s->H, s->c());
    LinearFilterStep fs;
    fs.Phi = F - K * (H * F);
    fs.K = std::move(K);
    out.push_back(std::move(fs));
    if (options.progress) options.progress(k, T);
  }
  return LinearFilter(std::move(out), system.m0());
}

}  // namespace kfx
