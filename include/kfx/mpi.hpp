#pragma once
// MPI for the distributed filters and Monte Carlo of include/kfx/distributed.hpp (library kfx::kfx_mpi,
// built with -DKFX_WITH_MPI=ON; docs/scaling.md). kfx never calls MPI_Init or MPI_Finalize and never
// uses MPI_COMM_WORLD: the caller initializes MPI and passes a communicator, which kfx duplicates so
// that its messages cannot mix with the caller's.
#include <mpi.h>

#include <vector>

#include "kfx/distributed.hpp"

namespace kfx::mpi {

/// kfx's duplicate of the caller's communicator and the compensated-sum reduction on it.
class Communicator {
 public:
  /// Duplicates `comm` (MPI_Comm_dup; collective over comm). @throws kfx::Error if MPI is not
  /// initialized or the duplication fails.
  explicit Communicator(MPI_Comm comm);
  ~Communicator();  ///< frees the duplicate (unless MPI is already finalized)
  Communicator(const Communicator&) = delete;
  Communicator& operator=(const Communicator&) = delete;

  int rank() const { return rank_; }
  int size() const { return size_; }
  MPI_Comm comm() const { return comm_; }

  /// In place, on every rank: the CompensatedAdd of all ranks' (hi, lo) pairs — one MPI_Allreduce with
  /// a commutative user operation on a 2-double datatype. Same length on all ranks.
  void AllreduceCompensated(std::vector<double>& pairs) const;
  /// A Reducer for distributed.hpp that calls AllreduceCompensated (and counts the time spent in it);
  /// valid while this Communicator lives.
  Reducer MakeReducer();
  double reduce_seconds() const { return reduce_seconds_; }  ///< total time in MakeReducer's reductions
  long reduce_calls() const { return reduce_calls_; }

 private:
  MPI_Comm comm_ = MPI_COMM_NULL;
  MPI_Datatype pair_ = MPI_DATATYPE_NULL;
  MPI_Op op_ = MPI_OP_NULL;
  int rank_ = 0, size_ = 1;
  double reduce_seconds_ = 0.0;
  long reduce_calls_ = 0;
};

/// The block-diagonal (or banded) filter over MPI: rank p holds subsystems partition.first(p) ..; `slice`
/// is this rank's part of the system and y its measurement columns. Results do not depend on the number
/// of ranks (distributed.hpp).
SlicedRun RunDistributedCoupledFilter(Communicator& comm, const CoupledSystem& slice, CoupledFilterKind kind,
                                      Eigen::Index first, Eigen::Index granule, const TimeSeries& y);

/// MonteCarloPerformance with the runs spread over the ranks (run i uses Rng::StreamSeed(seed, i) on
/// whatever rank runs it); every rank returns the same result, which does not depend on the number of
/// ranks. truth, filter and options must be the same on every rank.
MonteCarloResult DistributedMonteCarloPerformance(Communicator& comm, const Model& truth, const LinearFilter& filter,
                                                  const MonteCarloOptions& options = MonteCarloOptions());

/// `kfx blockdiag` on this communicator: RunBlockDiagJob(job, rank, size, reducer).
BlockDiagSummary RunBlockDiagJob(Communicator& comm, const BlockDiagJob& job);

}  // namespace kfx::mpi
