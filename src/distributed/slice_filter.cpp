// What one rank does in the distributed block-diagonal and banded filters: CoupledFilterSlice (a step as
// Begin, reduction, Finish), a slice's whole run, and all slices emulated in one process
// (include/kfx/distributed.hpp).
#include "kfx/distributed.hpp"

#include <algorithm>
#include <exception>
#include <string>

#include "kfx/error.hpp"
#include "kfx/validation.hpp"
#include "methods/block_diagonal/block_diagonal_internal.hpp"

namespace kfx {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

struct CoupledFilterSlice::Work {
  detail::BlockDiagonalWorkspace ws;
  BlockDiagonalCovarianceStep st;
  MatrixXd Ng, U;
  Index d = 0, r = 0;
  CoupledStep masked;  // the step with missing measurements masked (MaskMissingMeasurements)
  VectorXd y_masked;
};

namespace {

Index PackedSize(Index r) { return r * (r + 1) / 2; }

// Pairs in the block-diagonal partial: N (packed lower), Y^T nu, and a failure flag.
Index PartialPairs(Index r) { return PackedSize(r) + r + 1; }

}  // namespace

CoupledFilterSlice::CoupledFilterSlice(CoupledFilterKind kind, Index first, Index granule, VectorXd x0,
                                       const MatrixXd& P0_blocks)
    : kind_(kind), first_(first), granule_(granule), c_(P0_blocks.rows()), x_(std::move(x0)), P_(P0_blocks) {
  if (kind != CoupledFilterKind::kBlockDiagonal && kind != CoupledFilterKind::kBanded) {
    throw Error(std::string("kind: expected block-diagonal or banded for a distributed filter, got ") + ToString(kind));
  }
  if (granule < 1) throw Error("granule: expected at least 1 subsystem, got " + std::to_string(granule));
  // An empty slice (a rank with no subsystems: fewer granules than ranks) starts at n, wherever that is.
  if (first < 0 || (P0_blocks.cols() > 0 && first % granule != 0)) {
    throw Error("first: expected a multiple of the granule " + std::to_string(granule) + ", got " +
                std::to_string(first));
  }
  if (c_ < 1 || P0_blocks.cols() % c_ != 0) {
    throw Error("P0: expected c x (count c) packed blocks, got " + ShapeString(P0_blocks));
  }
  RequireVector("x0", x_, P0_blocks.cols());
  RequireFinite("x0", x_);
  RequireFinite("P0", P0_blocks);
  work_ = std::make_shared<Work>();
}

void CoupledFilterSlice::Begin(const CoupledStep& step, const VectorXd& measured) {
  const Index n = count(), d = step.d(), r = step.r();
  if (step.c() != c_ || step.n() != n) {
    throw Error("step: expected the slice's " + std::to_string(n) + " subsystems of " + std::to_string(c_) +
                " states, got " + std::to_string(step.n()) + " of " + std::to_string(step.c()));
  }
  RequireShape("step G", step.G, n * c_, r);
  RequireShape("step U", step.U, r, r);
  Work& w = *work_;
  // Missing measurements (NaN) as CoupledFilter::Step skips them; the masked step lives as long as the
  // step that Finish reads (step_).
  const bool missing = MaskMissingMeasurements(step, measured, &w.masked, &w.y_masked);
  const CoupledStep& s = missing ? w.masked : step;
  const VectorXd& y = missing ? w.y_masked : measured;
  w.d = d;
  w.r = r;
  if (n > 0) {
    xp_ = CoupledPropagate(s, x_);
    nu_ = y - BlockDiagonalApply(s.H, c_, xp_);
  } else {
    xp_.resize(0);
    nu_.resize(0);
  }
  if (kind_ == CoupledFilterKind::kBanded) {
    partial_.clear();
    if (n > 0) {
      BandedCovarianceStep st = BandedCovarianceUpdate(s, P_);
      x_ = xp_ + BlockDiagonalApply(st.K, d, nu_);
      P_ = std::move(st.P_filt);
    }
    begun_ = false;
    return;
  }
  partial_.assign(static_cast<size_t>(2 * PartialPairs(r)), 0.0);
  w.U = s.U;
  detail::BlockDiagonalResize(s, /*store_gain=*/false, &w.st);
  step_ = &s;
  double* pN = partial_.data();
  double* pY = partial_.data() + 2 * PackedSize(r);
  VectorXd ytnu(r);
  // One granule at a time, at the same global positions on every partition.
  for (Index b0 = 0; b0 < n; b0 += granule_) {
    const Index b1 = std::min(n, b0 + granule_);
    w.Ng.setZero(r, r);
    ytnu.setZero(r);
    detail::BlockDiagonalPass1(s, P_, b0, b1, nu_.data(), &w.ws, &w.st, &w.Ng, &ytnu);
    Index q = 0;
    for (Index j = 0; j < r; ++j) {
      for (Index i = j; i < r; ++i, ++q) CompensatedAccumulate(w.Ng(i, j), pN + 2 * q);
    }
    for (Index t = 0; t < r; ++t) CompensatedAccumulate(ytnu(t), pY + 2 * t);
  }
  begun_ = true;
}

void CoupledFilterSlice::Finish() {
  if (kind_ == CoupledFilterKind::kBanded) return;
  if (!begun_) throw Error("Finish: expected a Begin first");
  begun_ = false;
  Work& w = *work_;
  const Index n = count(), r = w.r;
  if (static_cast<Index>(partial_.size()) != 2 * PartialPairs(r)) {
    throw Error("partial: expected " + std::to_string(2 * PartialPairs(r)) + " numbers, got " +
                std::to_string(partial_.size()));
  }
  if (CompensatedValue(partial_.data() + 2 * (PartialPairs(r) - 1)) != 0.0) {
    throw Error("step: failed on another rank (see its message)");
  }
  MatrixXd N(r, r);
  Index q = 0;
  for (Index j = 0; j < r; ++j) {
    for (Index i = j; i < r; ++i, ++q) N(i, j) = N(j, i) = CompensatedValue(partial_.data() + 2 * q);
  }
  VectorXd ytnu(r);
  for (Index t = 0; t < r; ++t) ytnu(t) = CompensatedValue(partial_.data() + 2 * (PackedSize(r) + t));
  MatrixXd C1(r, r);
  detail::CouplingFactor factor;
  if (r > 0) factor = detail::BlockDiagonalFactor(w.U, N, &C1);
  const VectorXd v = C1 * ytnu;  // mu_u (empty when r = 0)
  if (n > 0) {
    if (step_ == nullptr) throw Error("Finish: the step passed to Begin is gone");
    x_ = xp_;  // pass 2 adds J nu - E mu_u granule by granule
    for (Index b0 = 0; b0 < n; b0 += granule_) {
      detail::BlockDiagonalPass2(*step_, factor, b0, std::min(n, b0 + granule_), nu_.data(), &v, x_.data(), &w.ws,
                                 &w.st);
    }
    P_.swap(w.st.P_filt);
  }
  step_ = nullptr;
  mu_u_ = v;
  sigma_u_ = C1;
}

void CoupledFilterSlice::Step(const CoupledStep& s, const VectorXd& y, const Reducer& reduce) {
  std::exception_ptr error;
  try {
    Begin(s, y);
  } catch (...) {
    if (kind_ == CoupledFilterKind::kBanded) throw;  // no reduction: the other ranks do not wait
    error = std::current_exception();
    partial_.assign(static_cast<size_t>(2 * PartialPairs(s.G.cols())), 0.0);
    partial_[partial_.size() - 2] = 1.0;  // the failure flag, seen by every rank after the reduction
    work_->r = s.G.cols();
    begun_ = true;
  }
  if (kind_ == CoupledFilterKind::kBanded) return;
  if (reduce) reduce(partial_);
  if (error) {
    begun_ = false;
    std::rethrow_exception(error);
  }
  Finish();
}

SlicedRun RunCoupledFilterSlice(const CoupledSystem& slice, CoupledFilterKind kind, Index first, Index granule,
                                const TimeSeries& y, const Reducer& reduce) {
  if (y.cols() != slice.meas_dim()) {
    throw Error("y: expected " + std::to_string(slice.meas_dim()) + " columns (the slice's count d), got " +
                std::to_string(y.cols()));
  }
  const int T = slice.ResolveSteps(static_cast<int>(y.rows()));
  CoupledFilterSlice filter(kind, first, granule, slice.m0(), slice.P0_blocks());
  SlicedRun run;
  run.x_filt.resize(T + 1, slice.state_dim());
  run.x_filt.row(0) = slice.m0().transpose();
  if (kind == CoupledFilterKind::kBlockDiagonal) run.coupling.resize(T, slice.r());
  for (int k = 1; k <= T; ++k) {
    filter.Step(*slice.step(k), y.row(k - 1).transpose(), reduce);
    run.x_filt.row(k) = filter.x().transpose();
    if (kind == CoupledFilterKind::kBlockDiagonal) run.coupling.row(k - 1) = filter.coupling_mean().transpose();
  }
  run.P_filt = filter.P();
  run.coupling_cov = filter.coupling_cov();
  return run;
}

std::vector<SlicedRun> RunCoupledFilterPartitioned(const CoupledSystem& system, CoupledFilterKind kind,
                                                   const Partition& partition, Index granule, const TimeSeries& y) {
  if (partition.begin.empty() || partition.begin.front() != 0 || partition.begin.back() != system.n()) {
    throw Error("partition: expected ranges covering the system's " + std::to_string(system.n()) + " subsystems");
  }
  if (y.cols() != system.meas_dim()) {
    throw Error("y: expected " + std::to_string(system.meas_dim()) + " columns (n d), got " + std::to_string(y.cols()));
  }
  const int T = system.ResolveSteps(static_cast<int>(y.rows()));
  const Index c = system.c(), d = system.d();
  const int P = partition.ranks();
  std::vector<CoupledFilterSlice> slices;
  std::vector<SlicedRun> runs(static_cast<size_t>(P));
  for (int p = 0; p < P; ++p) {
    const Index f = partition.first(p), m = partition.count(p);
    slices.emplace_back(kind, f, granule, system.m0().segment(f * c, m * c),
                        system.P0_blocks().middleCols(f * c, m * c));
    SlicedRun& run = runs[static_cast<size_t>(p)];
    run.x_filt.resize(T + 1, m * c);
    run.x_filt.row(0) = system.m0().segment(f * c, m * c).transpose();
    if (kind == CoupledFilterKind::kBlockDiagonal) run.coupling.resize(T, system.r());
  }
  for (int k = 1; k <= T; ++k) {
    const auto s = system.step(k);
    std::vector<CoupledStep> local(static_cast<size_t>(P));
    for (int p = 0; p < P; ++p) {
      local[static_cast<size_t>(p)] = SliceCoupledStep(*s, partition.first(p), partition.count(p));
      slices[static_cast<size_t>(p)].Begin(
          local[static_cast<size_t>(p)],
          y.row(k - 1).segment(partition.first(p) * d, partition.count(p) * d).transpose());
    }
    if (kind == CoupledFilterKind::kBlockDiagonal) {
      std::vector<double> total(slices[0].partial().size(), 0.0);
      for (auto& sl : slices) CompensatedAdd(sl.partial().data(), total.data(), static_cast<Index>(total.size() / 2));
      for (auto& sl : slices) sl.partial() = total;
    }
    for (int p = 0; p < P; ++p) {
      CoupledFilterSlice& sl = slices[static_cast<size_t>(p)];
      sl.Finish();
      runs[static_cast<size_t>(p)].x_filt.row(k) = sl.x().transpose();
      if (kind == CoupledFilterKind::kBlockDiagonal) {
        runs[static_cast<size_t>(p)].coupling.row(k - 1) = sl.coupling_mean().transpose();
      }
    }
  }
  for (int p = 0; p < P; ++p) {
    runs[static_cast<size_t>(p)].P_filt = slices[static_cast<size_t>(p)].P();
    runs[static_cast<size_t>(p)].coupling_cov = slices[static_cast<size_t>(p)].coupling_cov();
  }
  return runs;
}

}  // namespace kfx
