// What one rank does in the distributed block-diagonal and banded filters and the distributed Monte
// Carlo (include/kfx/distributed.hpp), free of MPI; the job of `kfx blockdiag`.
#include "kfx/distributed.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exception>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "core/performance_internal.hpp"
#include "kfx/coupled_model_file.hpp"
#include "kfx/error.hpp"
#include "kfx/io.hpp"
#include "kfx/simulation.hpp"
#include "kfx/validation.hpp"
#include "methods/block_diagonal/block_diagonal_internal.hpp"

namespace kfx {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;
namespace fs = std::filesystem;

// ---- Partition -------------------------------------------------------------------------------------

Partition PartitionByCost(Index n, int ranks, Index granule, const VectorXd& cost) {
  if (n < 1) throw Error("n: expected at least 1 subsystem, got " + std::to_string(n));
  if (ranks < 1) throw Error("ranks: expected at least 1, got " + std::to_string(ranks));
  if (granule < 1) throw Error("granule: expected at least 1 subsystem, got " + std::to_string(granule));
  if (cost.size() != 0) {
    RequireVector("cost", cost, n);
    RequireFinite("cost", cost);
    if ((cost.array() < 0.0).any()) throw Error("cost: expected non-negative weights");
  }
  const Index granules = (n + granule - 1) / granule;
  // prefix[j]: cost of granules [0, j).
  VectorXd prefix(granules + 1);
  prefix(0) = 0.0;
  for (Index j = 0; j < granules; ++j) {
    const Index i0 = j * granule, i1 = std::min(n, i0 + granule);
    prefix(j + 1) = prefix(j) + (cost.size() == 0 ? static_cast<double>(i1 - i0) : cost.segment(i0, i1 - i0).sum());
  }
  Partition p;
  p.begin.assign(static_cast<size_t>(ranks) + 1, 0);
  Index j = 0;
  for (int q = 1; q < ranks; ++q) {
    const double target = prefix(granules) * q / ranks;
    while (j < granules && prefix(j + 1) <= target) ++j;
    // j is the last boundary with prefix <= target; take j + 1 if it is nearer.
    if (j < granules && prefix(j + 1) - target <= target - prefix(j)) ++j;
    p.begin[static_cast<size_t>(q)] = std::min(n, j * granule);
  }
  p.begin.back() = n;
  return p;
}

double BlockDiagonalSubsystemCost(Index c, Index d, Index r) {
  const double cc = static_cast<double>(c), dd = static_cast<double>(d), rr = static_cast<double>(r);
  return cc * cc * cc + cc * cc * dd + cc * dd * dd + dd * dd * dd + (cc + dd) * rr * rr;
}

CoupledStep SliceCoupledStep(const CoupledStep& s, Index first, Index count) {
  const Index n = s.n(), c = s.c(), d = s.d();
  if (first < 0 || count < 0 || first + count > n) {
    throw Error("slice: expected a range of subsystems within [0, " + std::to_string(n) + "), got [" +
                std::to_string(first) + ", " + std::to_string(first + count) + ")");
  }
  CoupledStep out;
  out.F = s.F.middleCols(first * c, count * c);
  out.H = s.H.middleCols(first * c, count * c);
  out.V = s.V.middleCols(first * c, count * c);
  out.R = s.R.middleCols(first * d, count * d);
  out.G = s.G.middleRows(first * c, count * c);
  out.U = s.U;
  return out;
}

CoupledSystem SliceCoupledSystem(const CoupledSystem& system, Index first, Index count) {
  const Index c = system.c();
  if (first < 0 || count < 1 || first + count > system.n()) {
    throw Error("slice: expected a non-empty range of subsystems within [0, " + std::to_string(system.n()) +
                "), got [" + std::to_string(first) + ", " + std::to_string(first + count) + ")");
  }
  VectorXd m0 = system.m0().segment(first * c, count * c);
  MatrixXd P0 = system.P0_blocks().middleCols(first * c, count * c);
  if (system.time_invariant()) return CoupledSystem(SliceCoupledStep(*system.step(1), first, count), m0, P0);
  return CoupledSystem(
      count, c, system.d(), system.r(),
      [system, first, count](int k) { return SliceCoupledStep(*system.step(k), first, count); }, m0, P0,
      system.horizon());
}

// ---- Compensated sums ------------------------------------------------------------------------------

namespace {

// s + e = a + b exactly (Knuth's TwoSum).
inline void TwoSum(double a, double b, double* s, double* e) {
  *s = a + b;
  const double bb = *s - a;
  *e = (a - (*s - bb)) + (b - bb);
}

}  // namespace

void CompensatedAdd(const double* in, double* inout, Index pairs) {
  for (Index j = 0; j < pairs; ++j) {
    double s, e;
    TwoSum(in[2 * j], inout[2 * j], &s, &e);
    e += in[2 * j + 1] + inout[2 * j + 1];
    inout[2 * j] = s + e;  // renormalize (fast two-sum: |s| >= |e|)
    inout[2 * j + 1] = e - (inout[2 * j] - s);
  }
}

void CompensatedAccumulate(double value, double* pair) {
  double s, e;
  TwoSum(pair[0], value, &s, &e);
  e += pair[1];
  pair[0] = s + e;
  pair[1] = e - (pair[0] - s);
}

// ---- The slice of a distributed filter -------------------------------------------------------------

struct CoupledFilterSlice::Work {
  detail::BlockDiagonalWorkspace ws;
  BlockDiagonalCovarianceStep st;
  MatrixXd Ng, U;
  Index d = 0, r = 0;
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
  if (first < 0 || first % granule != 0) {
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

void CoupledFilterSlice::Begin(const CoupledStep& s, const VectorXd& y) {
  const Index n = count(), d = s.d(), r = s.r();
  if (s.c() != c_ || s.n() != n) {
    throw Error("step: expected the slice's " + std::to_string(n) + " subsystems of " + std::to_string(c_) +
                " states, got " + std::to_string(s.n()) + " of " + std::to_string(s.c()));
  }
  RequireShape("step G", s.G, n * c_, r);
  RequireShape("step U", s.U, r, r);
  RequireVector("y", y, n * d);
  RequireFinite("y", y);
  Work& w = *work_;
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
  const VectorXd v = C1 * ytnu;  // mu_u
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

// ---- Distributed Monte Carlo -----------------------------------------------------------------------

std::vector<double> MonteCarloPartialSums(const Model& truth, const LinearFilter& filter,
                                          const MonteCarloOptions& options, int first_run, int count) {
  const int T = detail::CheckMonteCarloEvaluation(truth, filter, options);
  if (first_run < 0 || count < 0 || count > options.runs - first_run) {
    throw Error("runs: expected a range within [0, " + std::to_string(options.runs) + "), got [" +
                std::to_string(first_run) + ", " + std::to_string(first_run + count) + ")");
  }
  const Index n = truth.state_dim();
  const Index steps = T + 1;
  const Index size = 4 * steps + steps * n + (options.store_error_moments ? steps * n * n : 0);
  std::vector<double> sums(static_cast<size_t>(2 * size), 0.0);
  double* s = sums.data();
  for (int run = first_run; run < first_run + count; ++run) {
    Rng rng(Rng::StreamSeed(options.seed, static_cast<std::uint64_t>(run)));
    const Trajectory tr = Simulate(truth, T, rng);
    const TimeSeries err = tr.x - RunLinearFilter(filter, tr.y);
    for (Index k = 0; k < steps; ++k) {
      const VectorXd e = err.row(k).transpose();
      const double v = e.squaredNorm();
      const double wv = options.weight.size() == 0 ? v : e.dot(options.weight * e);
      CompensatedAccumulate(v, s + 2 * k);
      CompensatedAccumulate(v * v, s + 2 * (steps + k));
      CompensatedAccumulate(wv, s + 2 * (2 * steps + k));
      CompensatedAccumulate(wv * wv, s + 2 * (3 * steps + k));
      double* b = s + 2 * (4 * steps + k * n);
      for (Index i = 0; i < n; ++i) CompensatedAccumulate(e(i), b + 2 * i);
      if (options.store_error_moments) {
        double* m = s + 2 * (4 * steps + steps * n + k * n * n);
        for (Index j = 0; j < n; ++j) {
          for (Index i = 0; i < n; ++i) CompensatedAccumulate(e(i) * e(j), m + 2 * (j * n + i));
        }
      }
    }
    if (options.progress) options.progress(run - first_run + 1, count);
  }
  return sums;
}

namespace {

// (S2 - S1^2 / R) from compensated S1, S2, with the products and the difference in double-double.
double CenteredSum(const double* s1, const double* s2, double R) {
  const double qh = s1[0] / R;
  const double ql = (std::fma(-qh, R, s1[0]) + s1[1]) / R;  // S1 / R = qh + ql
  const double p = s1[0] * qh;
  const double pe = std::fma(s1[0], qh, -p) + s1[0] * ql + s1[1] * qh;  // S1^2 / R = p + pe
  double t, e;
  TwoSum(s2[0], -p, &t, &e);
  return t + (e + s2[1] - pe);
}

}  // namespace

MonteCarloResult MonteCarloFromSums(const Model& truth, const LinearFilter& filter, const MonteCarloOptions& options,
                                    const std::vector<double>& sums) {
  const int T = detail::CheckMonteCarloEvaluation(truth, filter, options);
  const Index n = truth.state_dim(), steps = T + 1;
  const Index size = 4 * steps + steps * n + (options.store_error_moments ? steps * n * n : 0);
  if (static_cast<Index>(sums.size()) != 2 * size) {
    throw Error("sums: expected " + std::to_string(2 * size) + " numbers, got " + std::to_string(sums.size()));
  }
  const double R = options.runs;
  const double* s = sums.data();
  MonteCarloResult res;
  res.runs = options.runs;
  res.mse.resize(steps);
  res.weighted_mse.resize(steps);
  res.mse_std_error.resize(steps);
  res.weighted_mse_std_error.resize(steps);
  res.bias.resize(steps, n);
  for (Index k = 0; k < steps; ++k) {
    res.mse(k) = CompensatedValue(s + 2 * k) / R;
    res.weighted_mse(k) = CompensatedValue(s + 2 * (2 * steps + k)) / R;
    const double m2 = std::max(0.0, CenteredSum(s + 2 * k, s + 2 * (steps + k), R));
    const double wm2 = std::max(0.0, CenteredSum(s + 2 * (2 * steps + k), s + 2 * (3 * steps + k), R));
    res.mse_std_error(k) = std::sqrt(m2 / (R - 1.0) / R);
    res.weighted_mse_std_error(k) = std::sqrt(wm2 / (R - 1.0) / R);
    for (Index i = 0; i < n; ++i) res.bias(k, i) = CompensatedValue(s + 2 * (4 * steps + k * n + i)) / R;
    if (options.store_error_moments) {
      MatrixXd M(n, n);
      const double* m = s + 2 * (4 * steps + steps * n + k * n * n);
      for (Index j = 0; j < n; ++j) {
        for (Index i = 0; i < n; ++i) M(i, j) = CompensatedValue(m + 2 * (j * n + i)) / R;
      }
      res.error_moment.push_back(std::move(M));
    }
  }
  return res;
}

// ---- `kfx blockdiag` ------------------------------------------------------------------------------

namespace {

using nlohmann::json;

[[noreturn]] void FailField(const std::string& path, const std::string& field, const std::string& what) {
  throw Error(path + ": field '" + field + "': " + what);
}

json ReadJson(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error(path + ": cannot open file for reading");
  try {
    return json::parse(in);
  } catch (const json::exception& e) {
    throw Error(path + ": not valid JSON (" + e.what() + ")");
  }
}

Index PositiveField(const std::string& path, const json& j, const char* key, Index min) {
  if (!j.contains(key) || !j[key].is_number_integer() || j[key].get<long long>() < min) {
    FailField(path, key, "expected an integer >= " + std::to_string(min));
  }
  return j[key].get<Index>();
}

std::string SliceName(const std::string& what, Index first, Index end) {
  return what + "." + std::to_string(first) + "-" + std::to_string(end) + ".npy";
}

// Every rank learns whether any rank failed (one reduction of a flag), so no rank waits in a later
// reduction for a rank that has stopped.
void AgreeOnFailure(const std::exception_ptr& error, const Reducer& reduce) {
  std::vector<double> flag = {error ? 1.0 : 0.0, 0.0};
  if (reduce) reduce(flag);
  if (error) std::rethrow_exception(error);
  if (CompensatedValue(flag.data()) != 0.0) throw Error("blockdiag: failed on another rank (see its message)");
}

}  // namespace

BlockDiagSummary RunBlockDiagJob(const BlockDiagJob& job, int rank, int ranks, const Reducer& reduce) {
  if (ranks < 1 || rank < 0 || rank >= ranks) {
    throw Error("rank: expected 0 <= rank < ranks, got " + std::to_string(rank) + " of " + std::to_string(ranks));
  }
  BlockDiagSummary sum;
  sum.ranks = ranks;
  CoupledModelHeader h;
  Partition part;
  std::unique_ptr<CoupledSystem> slice;
  TimeSeries y;
  std::exception_ptr error;
  try {
    if (job.kind != CoupledFilterKind::kBlockDiagonal && job.kind != CoupledFilterKind::kBanded) {
      throw Error("kind: expected block-diagonal or banded");
    }
    h = ReadCoupledModelHeader(job.model);
    part = PartitionByCost(h.n, ranks, job.granule);
    sum.n = h.n;
    sum.first = part.first(rank);
    sum.count = part.count(rank);
    const NpyArray head = ReadNpySlice(job.data, 0, 0, 0);  // header only: the shape with axis 0 set to 0
    if (head.shape.size() != 2 || head.shape[1] != h.n * h.d) {
      throw Error(job.data + ": expected measurements of shape (T, " + std::to_string(h.n * h.d) + ") (n d columns)");
    }
    const auto rows = static_cast<int>(ReadNpySlice(job.data, 1, 0, 0).shape[0]);  // header only
    sum.steps = job.steps < 0 ? rows : job.steps;
    if (sum.steps > rows) {
      throw Error("steps: expected at most " + std::to_string(rows) + " (the rows of " + job.data + "), got " +
                  std::to_string(sum.steps));
    }
    fs::create_directories(job.out_dir);
    if (sum.count > 0) {
      slice = std::make_unique<CoupledSystem>(LoadCoupledModelSlice(job.model, sum.first, sum.count));
      const NpyArray a = ReadNpySlice(job.data, 1, sum.first * h.d, sum.count * h.d);
      y = Eigen::Map<const TimeSeries>(a.data.data(), a.shape[0], a.shape[1]).topRows(sum.steps);
    }
  } catch (...) {
    error = std::current_exception();
  }
  AgreeOnFailure(error, reduce);

  const auto t0 = std::chrono::steady_clock::now();
  SlicedRun run;
  try {
    if (sum.count > 0) {
      run = RunCoupledFilterSlice(*slice, job.kind, sum.first, job.granule, y, reduce);
    } else {
      // An empty slice still takes part in every reduction.
      CoupledFilterSlice empty(job.kind, sum.first, job.granule, VectorXd(0), MatrixXd(h.c, 0));
      CoupledStep s0;
      s0.F.resize(h.c, 0), s0.H.resize(h.d, 0), s0.V.resize(h.c, 0), s0.R.resize(h.d, 0);
      s0.G.resize(0, h.r);
      s0.U = h.U;  // every rank factors the same U
      run.x_filt.resize(sum.steps + 1, 0);
      run.coupling.resize(job.kind == CoupledFilterKind::kBlockDiagonal ? sum.steps : 0, h.r);
      for (int k = 1; k <= sum.steps; ++k) {
        empty.Step(s0, VectorXd(0), reduce);
        if (job.kind == CoupledFilterKind::kBlockDiagonal) run.coupling.row(k - 1) = empty.coupling_mean().transpose();
      }
      run.P_filt = MatrixXd(h.c, 0);
      run.coupling_cov = empty.coupling_cov();
    }
  } catch (...) {
    error = std::current_exception();
  }
  sum.seconds_filter = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  AgreeOnFailure(error, reduce);

  const Index end = sum.first + sum.count, c = h.c;
  const fs::path dir(job.out_dir);
  WriteNpyMatrix((dir / SliceName("x_filt", sum.first, end)).string(), run.x_filt);
  std::vector<double> P(static_cast<size_t>(sum.count * c * c));
  for (Index i = 0; i < sum.count; ++i) {
    for (Index p = 0; p < c; ++p) {
      for (Index q = 0; q < c; ++q) P[static_cast<size_t>((i * c + p) * c + q)] = run.P_filt(p, i * c + q);
    }
  }
  WriteNpy((dir / SliceName("P_filt", sum.first, end)).string(), {sum.count, c, c}, P.data());
  if (rank == 0) {
    if (job.kind == CoupledFilterKind::kBlockDiagonal) {
      WriteNpyMatrix((dir / "coupling_mean.npy").string(), run.coupling);
      WriteNpyMatrix((dir / "coupling_cov.npy").string(), run.coupling_cov);
    }
    json meta;
    meta["format"] = "kfx-blockdiag-output";
    meta["filter"] = ToString(job.kind);
    meta["n"] = h.n, meta["c"] = h.c, meta["d"] = h.d, meta["r"] = h.r;
    meta["steps"] = sum.steps;
    meta["ranks"] = ranks;
    meta["granule"] = job.granule;
    json slices = json::array();
    for (int p = 0; p < ranks; ++p) {
      const Index f = part.first(p), e = f + part.count(p);
      slices.push_back({{"first", f},
                        {"count", e - f},
                        {"x_filt", SliceName("x_filt", f, e)},
                        {"P_filt", SliceName("P_filt", f, e)}});
    }
    meta["slices"] = slices;
    std::ofstream out(dir / "metadata.json");
    out << meta.dump(1) << "\n";
    if (!out) throw Error((dir / "metadata.json").string() + ": cannot write");
  }
  return sum;
}

TimeSeries ReadBlockDiagStates(const std::string& out_dir) {
  const fs::path dir(out_dir);
  const std::string path = (dir / "metadata.json").string();
  const json meta = ReadJson(path);
  if (!meta.is_object() || meta.value("format", "") != "kfx-blockdiag-output") {
    throw Error(path + ": expected \"format\": \"kfx-blockdiag-output\"");
  }
  const Index n = PositiveField(path, meta, "n", 1), c = PositiveField(path, meta, "c", 1);
  const Index T = PositiveField(path, meta, "steps", 0);
  TimeSeries x(T + 1, n * c);
  for (const json& sl : meta.at("slices")) {
    const Index f = sl.at("first").get<Index>(), m = sl.at("count").get<Index>();
    if (m == 0) continue;
    const MatrixXd part = ReadNpyMatrix((dir / sl.at("x_filt").get<std::string>()).string());
    if (part.rows() != T + 1 || part.cols() != m * c || f < 0 || f + m > n) {
      throw Error(path + ": slice " + sl.dump() + " does not match its file");
    }
    x.middleCols(f * c, m * c) = part;
  }
  return x;
}

}  // namespace kfx
