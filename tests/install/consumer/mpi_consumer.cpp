// A user of kfx::kfx_mpi (find_package(kfx COMPONENTS mpi)), run by tests/install/run.sh under mpirun:
// kfx's compensated all-reduce of every rank's number against the closed-form sum.
#include <mpi.h>
#include <kfx/mpi.hpp>

#include <cstdio>
#include <vector>

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  int ok = 0;
  {
    const kfx::mpi::Communicator comm(MPI_COMM_WORLD);
    const int n = comm.size();
    // (hi, lo) pairs: rank k contributes (k + 1, 1e-20 (k + 1)); the sum is n (n + 1) / 2 (1 + 1e-20).
    std::vector<double> pairs = {comm.rank() + 1.0, 1e-20 * (comm.rank() + 1.0)};
    comm.AllreduceCompensated(pairs);
    const double expected = n * (n + 1) / 2.0;
    ok = pairs[0] == expected && pairs[1] > 0.5e-20 * expected && pairs[1] < 2e-20 * expected;
    std::printf("rank %d of %d: sum %.17g + %.3g (expected %.17g)\n", comm.rank(), n, pairs[0], pairs[1], expected);
  }
  int all_ok = 0;
  MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
  MPI_Finalize();
  return all_ok ? 0 : 1;
}
