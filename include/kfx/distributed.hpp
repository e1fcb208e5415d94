#pragma once
// The block-diagonal filter, the banded filter and Monte Carlo spread over processes (issue 10;
// docs/scaling.md). This header is free of MPI: it holds what one process (rank) does, and the
// combination of the ranks' partial sums is passed in as a Reducer. include/kfx/mpi.hpp supplies the
// MPI reducer (one MPI_Allreduce per step); a Reducer that does nothing runs everything in one process.
//
// Each rank holds a contiguous slice [first, first + count) of the n subsystems: its blocks of F, H, V,
// R, P, its rows of G and x, its columns of y. The block-diagonal step needs from the other ranks only
//   N = sum_i G_i^T H_i^T M_i^{-1} H_i G_i  (r x r symmetric, eq. (16))  and  Y^T nu = sum_i Y_i^T nu_i (r),
// so a rank sends r (r + 1) / 2 + r numbers per step and every rank repeats the r x r factorization.
//
// Independence of the number of ranks: the slices are made of whole granules of subsystems at fixed
// global positions, and every granule's partial sums are computed by the same code on the same data
// whatever rank holds it. The granules' partial sums are added in double-double arithmetic (a
// compensated (hi, lo) pair per entry, error ~ 1e-32 relative), so the order of the additions — which
// MPI_Allreduce does not fix — changes the rounded sum only when it lies within ~1e-32 of a rounding
// boundary. In practice np = 1, 2, 4 give the same bits (tests/distributed/distributed_test.cpp,
// tests/mpi/mpi_distributed_check.cpp measure the difference).
#include <Eigen/Dense>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "kfx/block_diagonal.hpp"
#include "kfx/linear_filter.hpp"
#include "kfx/model.hpp"
#include "kfx/performance.hpp"

namespace kfx {

// ---- Partition -------------------------------------------------------------------------------------

/// Contiguous ranges of subsystems, one per rank: rank p holds [begin[p], begin[p + 1]).
struct Partition {
  std::vector<Eigen::Index> begin;  ///< ranks + 1 entries, begin[0] = 0, begin.back() = n
  int ranks() const { return static_cast<int>(begin.size()) - 1; }
  Eigen::Index first(int rank) const { return begin[static_cast<size_t>(rank)]; }
  Eigen::Index count(int rank) const { return begin[static_cast<size_t>(rank) + 1] - begin[static_cast<size_t>(rank)]; }
};

/// Splits n subsystems into `ranks` contiguous ranges of whole granules (the last granule may be
/// short), balanced by cost: rank p's range ends at the granule boundary nearest to where the cumulative
/// cost reaches (p + 1) / ranks of the total. `cost` holds one non-negative weight per subsystem (empty:
/// the same for all, the case of CoupledStep, whose subsystems share c and d). Ranks may get an empty
/// range when there are fewer granules than ranks.
/// @throws kfx::Error for n < 1, ranks < 1, granule < 1, or a cost of the wrong length / negative / NaN.
Partition PartitionByCost(Eigen::Index n, int ranks, Eigen::Index granule,
                          const Eigen::VectorXd& cost = Eigen::VectorXd());

/// Per-subsystem cost of one block-diagonal step in flops, c^3 + c^2 d + c d^2 + d^3 + (c + d) r^2 (the
/// weight a caller with subsystems of different sizes passes to PartitionByCost, summed per subsystem).
double BlockDiagonalSubsystemCost(Eigen::Index c, Eigen::Index d, Eigen::Index r);

/// Subsystems [first, first + count) of a coupled step: packed blocks, rows of G; U unchanged.
/// @throws kfx::Error if the range is outside [0, n).
CoupledStep SliceCoupledStep(const CoupledStep& s, Eigen::Index first, Eigen::Index count);
/// The same slice of a time-invariant coupled system (with the prior's blocks).
CoupledSystem SliceCoupledSystem(const CoupledSystem& system, Eigen::Index first, Eigen::Index count);

// ---- Compensated (double-double) sums --------------------------------------------------------------

/// inout[j] += in[j] for `pairs` (hi, lo) pairs (2 pairs doubles each): the reduction operator of the
/// distributed sums (commutative; exact to ~1e-32 relative).
void CompensatedAdd(const double* in, double* inout, Eigen::Index pairs);
/// pair += value (pair is (hi, lo)).
void CompensatedAccumulate(double value, double* pair);
/// hi + lo rounded to double.
inline double CompensatedValue(const double* pair) { return pair[0] + pair[1]; }

/// Combines the ranks' partial sums, in place: on return `pairs` holds, on every rank, the
/// CompensatedAdd of all ranks' buffers (same length on all ranks). Empty function: one process.
using Reducer = std::function<void(std::vector<double>& pairs)>;

// ---- The slice of a distributed filter -------------------------------------------------------------

/// What one rank holds of a distributed block-diagonal (or banded) filter: the state, covariance blocks
/// and gain of subsystems [first, first + count). Each step is Begin (local pass 1 and partial sums),
/// the reduction of partial() over all slices, Finish (factorization and pass 2). The banded filter
/// needs no reduction: Begin does the whole step and partial() is empty.
class CoupledFilterSlice {
 public:
  /// @param kind kBlockDiagonal or kBanded. @param first global index of the slice's first subsystem;
  /// it and the slice's end must lie on multiples of `granule` (or the end at n).
  /// @param x0 length count c; @param P0_blocks c x (count c). @throws kfx::Error on invalid input.
  CoupledFilterSlice(CoupledFilterKind kind, Eigen::Index first, Eigen::Index granule, Eigen::VectorXd x0,
                     const Eigen::MatrixXd& P0_blocks);

  /// Local part of a step: s is the slice's step (count subsystems), y its measurements (count d).
  /// s must stay alive until Finish (pass 2 rereads G, H from it).
  /// @throws kfx::Error on shape mismatch or NaN/Inf in y.
  void Begin(const CoupledStep& s, const Eigen::VectorXd& y);
  /// The partial sums of this slice after Begin, as (hi, lo) pairs: the packed lower triangle of N
  /// (column by column, r (r + 1) / 2 pairs), then Y^T nu (r pairs). Replace by the sum over all slices
  /// (a Reducer) before Finish.
  std::vector<double>& partial() { return partial_; }
  /// Second part of the step. @throws kfx::NumericalError if I + S^T N S is not positive definite.
  void Finish();
  /// Begin, reduce(partial()), Finish.
  void Step(const CoupledStep& s, const Eigen::VectorXd& y, const Reducer& reduce);

  CoupledFilterKind kind() const { return kind_; }
  Eigen::Index first() const { return first_; }
  Eigen::Index count() const { return c_ > 0 ? x_.size() / c_ : 0; }
  const Eigen::VectorXd& x() const { return x_; }  ///< the slice's estimate (count c)
  const Eigen::MatrixXd& P() const { return P_; }  ///< c x (count c) packed covariance blocks
  /// Posterior of the coupling input after the last step, the same on every rank (block-diagonal only).
  const Eigen::VectorXd& coupling_mean() const { return mu_u_; }
  const Eigen::MatrixXd& coupling_cov() const { return sigma_u_; }

 private:
  struct Work;
  CoupledFilterKind kind_;
  Eigen::Index first_, granule_, c_;
  Eigen::VectorXd x_, xp_, nu_;
  Eigen::MatrixXd P_;
  Eigen::VectorXd mu_u_;
  Eigen::MatrixXd sigma_u_;
  std::vector<double> partial_;
  std::shared_ptr<Work> work_;
  const CoupledStep* step_ = nullptr;  // between Begin and Finish
  bool begun_ = false;
};

struct SlicedRun {
  TimeSeries x_filt;             ///< (T+1) x (count c), this slice's states; row 0 the prior mean
  Eigen::MatrixXd P_filt;        ///< c x (count c), the last covariance blocks
  TimeSeries coupling;           ///< T x r: mu_u,k (block-diagonal; the same on every rank)
  Eigen::MatrixXd coupling_cov;  ///< r x r, the last Sigma_u
};
/// Runs a slice of a filter over the slice's measurements y ((T, count d)), calling reduce once per step.
SlicedRun RunCoupledFilterSlice(const CoupledSystem& slice, CoupledFilterKind kind, Eigen::Index first,
                                Eigen::Index granule, const TimeSeries& y, const Reducer& reduce);

/// The distributed filter emulated in one process on the given partition: every slice's Begin, the
/// CompensatedAdd of their partial sums, every slice's Finish. Returns the slices' runs, in order (for
/// tests and for checking that results do not depend on the partition).
std::vector<SlicedRun> RunCoupledFilterPartitioned(const CoupledSystem& system, CoupledFilterKind kind,
                                                   const Partition& partition, Eigen::Index granule,
                                                   const TimeSeries& y);

// ---- Distributed Monte Carlo -----------------------------------------------------------------------

/// The sums over runs [first_run, first_run + count) of MonteCarloPerformance's per-run quantities, as
/// (hi, lo) pairs: |e_k|^2, |e_k|^4, e_k^T W e_k, (e_k^T W e_k)^2 (T + 1 each), e_k ((T + 1) n), and
/// e_k e_k^T ((T + 1) n^2, when options.store_error_moments). Run i uses Rng::StreamSeed(options.seed, i),
/// as MonteCarloPerformance does, so any split of the runs gives the same sums.
/// @throws kfx::Error as MonteCarloPerformance, or for a run range outside [0, options.runs).
std::vector<double> MonteCarloPartialSums(const Model& truth, const LinearFilter& filter,
                                          const MonteCarloOptions& options, int first_run, int count);
/// The MonteCarloResult from the sums over all options.runs runs.
MonteCarloResult MonteCarloFromSums(const Model& truth, const LinearFilter& filter, const MonteCarloOptions& options,
                                    const std::vector<double>& sums);

// ---- `kfx blockdiag` ------------------------------------------------------------------------------

/// `kfx blockdiag`: the job and what a rank does with it.
struct BlockDiagJob {
  std::string model;    ///< coupled model file (include/kfx/coupled_model_file.hpp)
  std::string data;     ///< measurements .npy, shape (T, n d); each rank reads its columns
  std::string out_dir;  ///< output directory (must exist or be creatable)
  CoupledFilterKind kind = CoupledFilterKind::kBlockDiagonal;  ///< or kBanded
  Eigen::Index granule = 1024;  ///< subsystems per reduction granule (the partition's unit)
  int steps = -1;               ///< negative: all rows of data
  /// The steady state of the block-diagonal filter (CoupledFilterOptions::steady_state_tolerance; 0 = off,
  /// range [0, 1e-2]): in one process only (ranks = 1), by RunCoupledFilter on the whole model.
  double steady_state_tolerance = 0.0;
};
struct BlockDiagSummary {
  Eigen::Index n = 0, first = 0, count = 0;
  int steps = 0, ranks = 1;
  double seconds_filter = 0.0;  ///< time in the filter steps on this rank
  int steady_state_steps = 0;   ///< steps done on the frozen gain (job.steady_state_tolerance)
};
/// Runs rank `rank` of `ranks`: reads its slice, filters, writes DIR/x_filt.<first>-<end>.npy (T + 1,
/// count c) and DIR/P_filt.<first>-<end>.npy (count, c, c); rank 0 also writes DIR/coupling_mean.npy
/// (T, r), DIR/coupling_cov.npy (r, r) and DIR/metadata.json (every slice's file and range).
/// @throws kfx::Error on bad input (the same on every rank, before any reduction).
BlockDiagSummary RunBlockDiagJob(const BlockDiagJob& job, int rank, int ranks, const Reducer& reduce);
/// Reads the x_filt of all slices listed in DIR/metadata.json into one (T + 1) x (n c) series.
TimeSeries ReadBlockDiagStates(const std::string& out_dir);

}  // namespace kfx
