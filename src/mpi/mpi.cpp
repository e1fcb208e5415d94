// The MPI layer of the distributed filters (include/kfx/mpi.hpp): communicator duplication, the
// compensated-sum MPI_Allreduce, and the distributed runs. Built only with -DKFX_WITH_MPI=ON.
#include "kfx/mpi.hpp"

#include <algorithm>
#include <string>

#include "kfx/error.hpp"

namespace kfx::mpi {

namespace {

void Check(int code, const char* what) {
  if (code != MPI_SUCCESS) {
    char text[MPI_MAX_ERROR_STRING];
    int len = 0;
    MPI_Error_string(code, text, &len);
    throw Error(std::string(what) + ": " + std::string(text, static_cast<size_t>(len)));
  }
}

// MPI_User_function: inout += in on (hi, lo) pairs.
void CompensatedSumOp(void* in, void* inout, int* len, MPI_Datatype* /*type*/) {
  CompensatedAdd(static_cast<const double*>(in), static_cast<double*>(inout), *len);
}

}  // namespace

Communicator::Communicator(MPI_Comm comm) {
  int initialized = 0, finalized = 0;
  MPI_Initialized(&initialized);
  MPI_Finalized(&finalized);
  if (!initialized || finalized) throw Error("comm: MPI is not initialized (the caller calls MPI_Init)");
  if (comm == MPI_COMM_NULL) throw Error("comm: expected a communicator, got MPI_COMM_NULL");
  Check(MPI_Comm_dup(comm, &comm_), "MPI_Comm_dup");
  MPI_Comm_rank(comm_, &rank_);
  MPI_Comm_size(comm_, &size_);
  Check(MPI_Type_contiguous(2, MPI_DOUBLE, &pair_), "MPI_Type_contiguous");
  Check(MPI_Type_commit(&pair_), "MPI_Type_commit");
  Check(MPI_Op_create(&CompensatedSumOp, /*commute=*/1, &op_), "MPI_Op_create");
}

Communicator::~Communicator() {
  int finalized = 0;
  MPI_Finalized(&finalized);
  if (finalized) return;
  if (op_ != MPI_OP_NULL) MPI_Op_free(&op_);
  if (pair_ != MPI_DATATYPE_NULL) MPI_Type_free(&pair_);
  if (comm_ != MPI_COMM_NULL) MPI_Comm_free(&comm_);
}

void Communicator::AllreduceCompensated(std::vector<double>& pairs) const {
  if (pairs.size() % 2 != 0) throw Error("pairs: expected an even number of doubles (hi, lo)");
  const int count = static_cast<int>(pairs.size() / 2);
  Check(MPI_Allreduce(MPI_IN_PLACE, pairs.data(), count, pair_, op_, comm_), "MPI_Allreduce");
}

Reducer Communicator::MakeReducer() {
  return [this](std::vector<double>& pairs) {
    const double t0 = MPI_Wtime();
    AllreduceCompensated(pairs);
    reduce_seconds_ += MPI_Wtime() - t0;
    ++reduce_calls_;
  };
}

SlicedRun RunDistributedCoupledFilter(Communicator& comm, const CoupledSystem& slice, CoupledFilterKind kind,
                                      Eigen::Index first, Eigen::Index granule, const TimeSeries& y) {
  return RunCoupledFilterSlice(slice, kind, first, granule, y, comm.MakeReducer());
}

MonteCarloResult DistributedMonteCarloPerformance(Communicator& comm, const Model& truth, const LinearFilter& filter,
                                                  const MonteCarloOptions& options) {
  // Contiguous runs per rank; the sums are split-independent (distributed.hpp).
  const int R = std::max(options.runs, 0), P = comm.size(), p = comm.rank();
  const int first = static_cast<int>(static_cast<long long>(R) * p / P);
  const int end = static_cast<int>(static_cast<long long>(R) * (p + 1) / P);
  MonteCarloOptions local = options;
  if (p != 0) local.progress = nullptr;
  std::vector<double> sums = MonteCarloPartialSums(truth, filter, local, first, end - first);
  comm.AllreduceCompensated(sums);
  return MonteCarloFromSums(truth, filter, options, sums);
}

BlockDiagSummary RunBlockDiagJob(Communicator& comm, const BlockDiagJob& job) {
  return kfx::RunBlockDiagJob(job, comm.rank(), comm.size(), comm.MakeReducer());
}

}  // namespace kfx::mpi
