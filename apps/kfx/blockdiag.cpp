// `kfx blockdiag`: thin; the work is kfx::RunBlockDiagJob (include/kfx/distributed.hpp). With MPI, the
// command (not the library) initializes MPI and passes MPI_COMM_WORLD to kfx::mpi::Communicator.
#include "commands.hpp"

#include <algorithm>
#include <cstdio>
#include <iostream>

#include "kfx/block_diagonal.hpp"
#include "kfx/distributed.hpp"
#include "kfx/enum_text.hpp"
#include "kfx/error.hpp"
#ifdef KFX_WITH_MPI
#include "kfx/mpi.hpp"
#endif

namespace kfx::cli {

namespace {

BlockDiagJob MakeJob(const BlockDiagArgs& a) {
  BlockDiagJob job;
  job.model = a.model;
  job.data = a.data;
  job.out_dir = a.out;
  job.kind = ParseEnum<CoupledFilterKind>("--filter", a.filter);
  job.granule = a.granule;
  job.steps = a.steps;
  job.steady_state_tolerance = a.steady_state_tolerance;
  return job;
}

void PrintSummary(const BlockDiagJob& job, const BlockDiagSummary& s, double max_seconds, double reduce_seconds) {
  std::cout << "blockdiag: " << ToString(job.kind) << " filter, n = " << s.n << " subsystems, " << s.steps << " steps, "
            << s.ranks << (s.ranks == 1 ? " rank" : " ranks") << "\n"
            << "  filter time " << max_seconds << " s (slowest rank)";
  if (reduce_seconds >= 0) std::cout << ", of which all-reduce " << reduce_seconds << " s";
  if (job.steady_state_tolerance > 0)
    std::cout << "\n  steady state: " << s.steady_state_steps << " steps on the frozen gain";
  std::cout << "\n  output: " << job.out_dir << "/metadata.json\n";
}

}  // namespace

int RunBlockDiag(int argc, char** argv, const BlockDiagArgs& a) {
  const BlockDiagJob job = MakeJob(a);
#ifdef KFX_WITH_MPI
  MPI_Init(&argc, &argv);
  int code = 0;
  {
    int rank = 0;
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    try {
      kfx::mpi::Communicator comm(MPI_COMM_WORLD);
      const BlockDiagSummary s = kfx::mpi::RunBlockDiagJob(comm, job);
      double max_seconds = 0.0, reduce = comm.reduce_seconds(), max_reduce = 0.0;
      MPI_Reduce(&s.seconds_filter, &max_seconds, 1, MPI_DOUBLE, MPI_MAX, 0, MPI_COMM_WORLD);
      MPI_Reduce(&reduce, &max_reduce, 1, MPI_DOUBLE, MPI_MAX, 0, MPI_COMM_WORLD);
      if (rank == 0) PrintSummary(job, s, max_seconds, max_reduce);
    } catch (const std::exception& e) {
      // Every rank knows of a failure (RunBlockDiagJob agrees on it); only the lowest rank that failed on its
      // own says why (the others hold "failed on another rank"): one line for the job, every rank exits 2.
      std::string msg = e.what();
      for (auto& ch : msg)
        if (ch == '\n' || ch == '\r') ch = ' ';
      if (msg.find("on another rank") == std::string::npos) {
        std::fprintf(stderr, "kfx: error (rank %d): %s\n", rank, msg.c_str());
      }
      code = 2;
    }
  }
  MPI_Finalize();
  return code;
#else
  (void)argc;
  (void)argv;
  const BlockDiagSummary s = RunBlockDiagJob(job, 0, 1, nullptr);
  PrintSummary(job, s, s.seconds_filter, -1.0);
  return 0;
#endif
}

}  // namespace kfx::cli
