// Per-step time of the distributed block-diagonal filter and the time of its one MPI_Allreduce
// (docs/scaling.md). Each rank builds only its slice: subsystem i's blocks come from the random stream
// Rng::StreamSeed(seed, i), so the system is the same for any number of ranks.
//   mpirun -np N bench_blockdiag_mpi [--n 100000] [--c 2] [--d 1] [--r 20] [--steps 6] [--granule 1024]
// Prints one line of key=value pairs (times in seconds; per-step times are the slowest rank's, median
// over the steps after the first).
#include <mpi.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "kfx/distributed.hpp"
#include "kfx/mpi.hpp"
#include "kfx/simulation.hpp"

namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  MPI_Init(&argc, &argv);
  long n = 100000, c = 2, d = 1, r = 20, steps = 6, granule = 1024, repeats = 2000;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i];
    const long v = std::atol(argv[i + 1]);
    if (k == "--n") n = v;
    if (k == "--c") c = v;
    if (k == "--d") d = v;
    if (k == "--r") r = v;
    if (k == "--steps") steps = v;
    if (k == "--granule") granule = v;
    if (k == "--repeats") repeats = v;
  }
  int code = 0;
  try {
    kfx::mpi::Communicator comm(MPI_COMM_WORLD);
    const kfx::Partition part = kfx::PartitionByCost(n, comm.size(), granule);
    const Index first = part.first(comm.rank()), m = part.count(comm.rank());
    // This rank's slice: stable F (0.9 I + small), random H, G; V, R, P0 multiples of I; U = I.
    kfx::CoupledStep s;
    s.F.resize(c, m * c), s.H.resize(d, m * c), s.V.resize(c, m * c), s.R.resize(d, m * d), s.G.resize(m * c, r);
    for (Index i = 0; i < m; ++i) {
      kfx::Rng rng(kfx::Rng::StreamSeed(1, static_cast<std::uint64_t>(first + i)));
      s.F.middleCols(i * c, c) =
          0.9 * MatrixXd::Identity(c, c) + 0.05 * MatrixXd::NullaryExpr(c, c, [&] { return rng.Normal(); });
      s.H.middleCols(i * c, c) = MatrixXd::NullaryExpr(d, c, [&] { return rng.Normal(); });
      s.V.middleCols(i * c, c) = 0.1 * MatrixXd::Identity(c, c);
      s.R.middleCols(i * d, d) = 0.5 * MatrixXd::Identity(d, d);
      s.G.middleRows(i * c, c) = MatrixXd::NullaryExpr(c, r, [&] { return 0.3 * rng.Normal(); });
    }
    s.U = MatrixXd::Identity(r, r);
    kfx::CoupledFilterSlice filter(kfx::CoupledFilterKind::kBlockDiagonal, first, granule, VectorXd::Zero(m * c),
                                   MatrixXd::Identity(c, c).replicate(1, m));
    const VectorXd y = VectorXd::Ones(m * d);
    const kfx::Reducer reduce = comm.MakeReducer();
    std::vector<double> step_max, reduce_max;
    for (long k = 0; k < steps; ++k) {
      MPI_Barrier(comm.comm());
      const double before = comm.reduce_seconds();
      const double t0 = MPI_Wtime();
      filter.Step(s, y, reduce);
      double dt = MPI_Wtime() - t0, dr = comm.reduce_seconds() - before, mt = 0.0, mr = 0.0;
      MPI_Allreduce(&dt, &mt, 1, MPI_DOUBLE, MPI_MAX, comm.comm());
      MPI_Allreduce(&dr, &mr, 1, MPI_DOUBLE, MPI_MAX, comm.comm());
      if (k > 0 || steps == 1) step_max.push_back(mt), reduce_max.push_back(mr);
    }
    // The all-reduce alone: the same message (r (r + 1) / 2 + r + 1 pairs), compensated and plain sum.
    std::vector<double> buf(static_cast<size_t>(2 * (r * (r + 1) / 2 + r + 1)), 1.0);
    MPI_Barrier(comm.comm());
    double t0 = MPI_Wtime();
    for (long k = 0; k < repeats; ++k) comm.AllreduceCompensated(buf);
    const double t_comp = (MPI_Wtime() - t0) / repeats;
    std::vector<double> plain(buf.size() / 2, 1.0), out(plain.size());
    MPI_Barrier(comm.comm());
    t0 = MPI_Wtime();
    for (long k = 0; k < repeats; ++k) {
      MPI_Allreduce(plain.data(), out.data(), static_cast<int>(plain.size()), MPI_DOUBLE, MPI_SUM, comm.comm());
    }
    const double t_plain = (MPI_Wtime() - t0) / repeats;
    // Single-process reference on this rank's slice: the library's CoupledFilter (no reduction).
    double t_serial = 0.0;
    if (comm.size() == 1) {
      kfx::CoupledFilter serial(kfx::CoupledFilterKind::kBlockDiagonal, VectorXd::Zero(m * c),
                                MatrixXd::Identity(c, c).replicate(1, m));
      std::vector<double> ts;
      for (long k = 0; k < steps; ++k) {
        const double t1 = MPI_Wtime();
        serial.Step(s, y);
        if (k > 0 || steps == 1) ts.push_back(MPI_Wtime() - t1);
      }
      t_serial = Median(ts);
    }
    if (comm.rank() == 0) {
      std::printf(
          "np=%d n=%ld c=%ld d=%ld r=%ld steps=%zu step_s=%.4g step_min_s=%.4g reduce_in_step_s=%.3g "
          "allreduce_compensated_s=%.3g allreduce_plain_s=%.3g message_doubles=%zu serial_CoupledFilter_step_s=%.4g\n",
          comm.size(), n, c, d, r, step_max.size(), Median(step_max),
          *std::min_element(step_max.begin(), step_max.end()), Median(reduce_max), t_comp, t_plain, buf.size(),
          t_serial);
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bench_blockdiag_mpi: %s\n", e.what());
    code = 2;
  }
  MPI_Finalize();
  return code;
}
