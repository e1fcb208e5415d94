// The distributed filters and Monte Carlo under mpirun (np = 1, 2, 4 from ctest), against the one-process
// code: the library's serial filters (a different summation order: agreement to rounding) and the
// partitioned run with a single slice (the np = 1 result: the np-independence check, 1e-13). Also the
// helper modes of tests/mpi/blockdiag_cli.sh: make-model DIR, compare DIR_A DIR_B, check-serial DIR MODEL Y.
#include <mpi.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "kfx/block_diagonal.hpp"
#include "kfx/coupled_model_file.hpp"
#include "kfx/distributed.hpp"
#include "kfx/error.hpp"
#include "kfx/io.hpp"
#include "kfx/mpi.hpp"
#include "kfx/performance.hpp"
#include "kfx/simulation.hpp"

namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;
using kfx::CoupledFilterKind;
using kfx::CoupledStep;
using kfx::CoupledSystem;

int g_failures = 0;

// max |a - b| / max(max |b|, tiny), or inf when the shapes differ.
double Rel(const MatrixXd& a, const MatrixXd& b) {
  if (a.rows() != b.rows() || a.cols() != b.cols()) return INFINITY;
  if (a.size() == 0) return 0.0;
  return (a - b).cwiseAbs().maxCoeff() / std::max(b.cwiseAbs().maxCoeff(), 1e-300);
}

// Prints on rank 0 the worst value over ranks; a failure on any rank counts once per rank.
void Expect(MPI_Comm comm, const std::string& what, double value, double tol) {
  double worst = 0.0;
  MPI_Allreduce(&value, &worst, 1, MPI_DOUBLE, MPI_MAX, comm);
  const bool ok = worst <= tol;
  if (!ok) ++g_failures;
  int rank = 0;
  MPI_Comm_rank(comm, &rank);
  if (rank == 0) std::printf("%-4s %-62s %.3g (tolerance %.0e)\n", ok ? "ok" : "FAIL", what.c_str(), worst, tol);
}

MatrixXd Spd(kfx::Rng& rng, Index a, double shift) {
  MatrixXd g(a, a);
  for (Index i = 0; i < g.size(); ++i) g(i) = rng.Normal();
  return g * g.transpose() / static_cast<double>(a) + shift * MatrixXd::Identity(a, a);
}

CoupledStep RandomStep(kfx::Rng& rng, Index n, Index c, Index d, Index r) {
  auto gauss = [&](Index rows, Index cols, double scale) {
    MatrixXd m(rows, cols);
    for (Index i = 0; i < m.size(); ++i) m(i) = scale * rng.Normal();
    return m;
  };
  CoupledStep s;
  s.F = gauss(c, n * c, 0.6);
  s.H = gauss(d, n * c, 1.0);
  s.V.resize(c, n * c);
  s.R.resize(d, n * d);
  for (Index i = 0; i < n; ++i) {
    s.V.middleCols(i * c, c) = Spd(rng, c, 0.05);
    s.R.middleCols(i * d, d) = Spd(rng, d, 0.2);
  }
  s.G = gauss(n * c, r, 0.7);
  s.U = Spd(rng, r, 0.1);
  return s;
}

CoupledSystem RandomSystem(std::uint64_t seed, Index n, Index c, Index d, Index r, int T) {
  kfx::Rng rng(seed);
  std::vector<CoupledStep> steps;
  for (int k = 0; k < T; ++k) steps.push_back(RandomStep(rng, n, c, d, r));
  VectorXd m0(n * c);
  for (Index i = 0; i < m0.size(); ++i) m0(i) = rng.Normal();
  MatrixXd P0(c, n * c);
  for (Index i = 0; i < n; ++i) P0.middleCols(i * c, c) = Spd(rng, c, 0.5);
  return CoupledSystem(std::move(steps), m0, P0);
}

// One configuration of the distributed filter on `comm`, checked against the one-process runs.
void CheckFilter(MPI_Comm raw, const std::string& label, Index n, Index c, Index d, Index r, Index granule,
                 CoupledFilterKind kind, bool cost_weighted) {
  kfx::mpi::Communicator comm(raw);
  const int T = 10;
  const CoupledSystem system = RandomSystem(1000 + n + 10 * c + 100 * d + r, n, c, d, r, T);
  const kfx::TimeSeries y = kfx::SimulateCoupled(system, {T, 77}).y;
  VectorXd cost;
  if (cost_weighted) cost = VectorXd::LinSpaced(n, 1.0, 5.0);  // e.g. subsystems of growing size
  const kfx::Partition part = kfx::PartitionByCost(n, comm.size(), granule, cost);
  const Index first = part.first(comm.rank()), count = part.count(comm.rank());
  if (count == 0) throw kfx::Error("test set-up: a rank without subsystems");
  const CoupledSystem slice = kfx::SliceCoupledSystem(system, first, count);
  const kfx::SlicedRun run =
      kfx::mpi::RunDistributedCoupledFilter(comm, slice, kind, first, granule, y.middleCols(first * d, count * d));
  // The np = 1 result, computed here in one process.
  const kfx::SlicedRun one =
      kfx::RunCoupledFilterPartitioned(system, kind, kfx::PartitionByCost(n, 1, granule), granule, y)[0];
  // The library's serial filter.
  const kfx::CoupledRun serial = kfx::RunCoupledFilter(system, kind, y);
  const std::string tag = label + " np=" + std::to_string(comm.size()) + ": ";
  Expect(raw, tag + "x vs np=1 (rel)", Rel(run.x_filt, one.x_filt.middleCols(first * c, count * c)), 1e-13);
  Expect(raw, tag + "P vs np=1 (rel)", Rel(run.P_filt, one.P_filt.middleCols(first * c, count * c)), 1e-13);
  Expect(raw, tag + "x vs serial RunCoupledFilter (rel)",
         Rel(run.x_filt, serial.x_filt.middleCols(first * c, count * c)), 1e-10);
  if (kind == CoupledFilterKind::kBlockDiagonal) {
    Expect(raw, tag + "coupling mean vs np=1 (rel)", Rel(run.coupling, one.coupling), 1e-13);
    Expect(raw, tag + "coupling mean vs serial (rel)", Rel(run.coupling, serial.coupling), 1e-10);
  }
}

void CheckMonteCarlo(MPI_Comm raw) {
  kfx::mpi::Communicator comm(raw);
  const CoupledSystem system = RandomSystem(5, 6, 2, 1, 2, 8);
  const kfx::Model truth = kfx::ToDenseModel(system);
  const kfx::LinearFilter filter = kfx::CoupledFilterAsLinearFilter(system, CoupledFilterKind::kBlockDiagonal, {8});
  kfx::MonteCarloOptions opt;
  opt.runs = 37;
  opt.seed = 3;
  opt.store_error_moments = true;
  const kfx::MonteCarloResult dist = kfx::mpi::DistributedMonteCarloPerformance(comm, truth, filter, opt);
  const kfx::MonteCarloResult serial = kfx::MonteCarloPerformance(truth, filter, opt);
  const kfx::MonteCarloResult one =
      kfx::MonteCarloFromSums(truth, filter, opt, kfx::MonteCarloPartialSums(truth, filter, opt, 0, opt.runs));
  const std::string tag = "Monte Carlo np=" + std::to_string(comm.size()) + ": ";
  Expect(raw, tag + "mse vs MonteCarloPerformance (rel)", Rel(dist.mse, serial.mse), 1e-12);
  Expect(raw, tag + "std error vs MonteCarloPerformance (rel)", Rel(dist.mse_std_error, serial.mse_std_error), 1e-10);
  Expect(raw, tag + "bias vs MonteCarloPerformance (rel)", Rel(dist.bias, serial.bias), 1e-12);
  Expect(raw, tag + "E[e e^T] at k=8 vs MonteCarloPerformance (rel)", Rel(dist.error_moment[8], serial.error_moment[8]),
         1e-12);
  Expect(raw, tag + "mse vs np=1 sums (rel)", Rel(dist.mse, one.mse), 1e-15);
  // And against the exact-performance engine: within 5 standard errors at the last step.
  const kfx::PerformanceResult exact = kfx::ExactPerformance(truth, filter);
  Expect(raw, tag + "|mse - exact| / std error at k=8", std::abs(dist.mse(8) - exact.mse(8)) / dist.mse_std_error(8),
         5.0);
}

// An infinite measurement in one rank's slice (NaN is a missing value, inf an error): every rank must get
// an error (none may wait in the reduction).
void CheckFailureAgreement(MPI_Comm raw) {
  kfx::mpi::Communicator comm(raw);
  const Index n = 16, c = 2, d = 1, r = 3, granule = 4;
  const CoupledSystem system = RandomSystem(9, n, c, d, r, 3);
  kfx::TimeSeries y = kfx::SimulateCoupled(system, {3, 1}).y;
  y(1, n * d - 1) = INFINITY;  // in the last rank's slice
  const kfx::Partition part = kfx::PartitionByCost(n, comm.size(), granule);
  const Index first = part.first(comm.rank()), count = part.count(comm.rank());
  double threw = 0.0;
  try {
    kfx::mpi::RunDistributedCoupledFilter(comm, kfx::SliceCoupledSystem(system, first, count),
                                          CoupledFilterKind::kBlockDiagonal, first, granule,
                                          y.middleCols(first * d, count * d));
  } catch (const kfx::Error&) {
    threw = 1.0;
  }
  Expect(raw, "inf on one rank: every rank raises kfx::Error (0 = yes)", 1.0 - threw, 0.0);
}

int RunChecks() {
  MPI_Comm world_copy;
  MPI_Comm_dup(MPI_COMM_WORLD, &world_copy);
  CheckFilter(world_copy, "block-diagonal c=2 d=1 r=5", 45, 2, 1, 5, 4, CoupledFilterKind::kBlockDiagonal, false);
  CheckFilter(world_copy, "block-diagonal c=3 d=2 r=3 cost-weighted", 40, 3, 2, 3, 2, CoupledFilterKind::kBlockDiagonal,
              true);
  CheckFilter(world_copy, "block-diagonal c=1 d=1 r=1", 33, 1, 1, 1, 3, CoupledFilterKind::kBlockDiagonal, false);
  CheckFilter(world_copy, "banded c=2 d=1 r=5", 45, 2, 1, 5, 4, CoupledFilterKind::kBanded, false);
  CheckMonteCarlo(world_copy);
  CheckFailureAgreement(world_copy);
  // The library works on any communicator: two halves run separate filters at the same time.
  int rank = 0, size = 1;
  MPI_Comm_rank(world_copy, &rank);
  MPI_Comm_size(world_copy, &size);
  if (size >= 2) {
    MPI_Comm half;
    MPI_Comm_split(world_copy, rank % 2, rank, &half);
    CheckFilter(half, "sub-communicator (rank % 2) c=2 d=1 r=4", 30, 2, 1, 4, 3, CoupledFilterKind::kBlockDiagonal,
                false);
    MPI_Comm_free(&half);
  }
  int total = 0;
  MPI_Allreduce(&g_failures, &total, 1, MPI_INT, MPI_SUM, world_copy);
  MPI_Comm_free(&world_copy);
  if (rank == 0) std::printf("%s\n", total == 0 ? "all checks passed" : "FAILED");
  return total == 0 ? 0 : 1;
}

// ---- Helper modes for tests/mpi/blockdiag_cli.sh (one process, no MPI calls) ------------------------

// n subsystems (50 by default; fewer than a granule and than the ranks in the few-subsystems runs); with
// `missing`, every 7th measurement is NaN (a missing value, skipped by every filter).
int MakeModel(const std::string& dir, Index n, bool missing) {
  std::filesystem::create_directories(dir);
  const Index c = 2, d = 1, r = 4;
  kfx::Rng rng(21);
  const CoupledStep s = RandomStep(rng, n, c, d, r);
  MatrixXd P0(c, n * c);
  for (Index i = 0; i < n; ++i) P0.middleCols(i * c, c) = Spd(rng, c, 0.5);
  const CoupledSystem system(s, VectorXd::Zero(n * c), P0);
  kfx::SaveCoupledModel(dir + "/model.json", system);
  MatrixXd y = kfx::SimulateCoupled(system, {12, 5}).y;
  if (missing) {
    for (Index i = 0; i < y.size(); i += 7) y.data()[i] = std::numeric_limits<double>::quiet_NaN();
  }
  kfx::WriteNpyMatrix(dir + "/y.npy", y);
  return 0;
}

int Compare(const std::string& a, const std::string& b, double tol) {
  const double rel = Rel(kfx::ReadBlockDiagStates(a), kfx::ReadBlockDiagStates(b));
  std::printf("x_filt %s vs %s: relative difference %.3g (tolerance %.0e)\n", a.c_str(), b.c_str(), rel, tol);
  return rel <= tol ? 0 : 1;
}

int CheckSerial(const std::string& dir, const std::string& model, const std::string& data, const std::string& kind) {
  const kfx::CoupledModelHeader h = kfx::ReadCoupledModelHeader(model);
  const CoupledSystem system = kfx::LoadCoupledModelSlice(model, 0, h.n);
  const CoupledFilterKind k = kind == "banded" ? CoupledFilterKind::kBanded : CoupledFilterKind::kBlockDiagonal;
  const kfx::CoupledRun serial = kfx::RunCoupledFilter(system, k, kfx::ReadTimeSeries(data));
  const double rel = Rel(kfx::ReadBlockDiagStates(dir), serial.x_filt);
  std::printf("x_filt %s vs serial RunCoupledFilter: relative difference %.3g (tolerance 1e-10)\n", dir.c_str(), rel);
  return rel <= 1e-10 ? 0 : 1;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    if (argc >= 3 && std::string(argv[1]) == "make-model") {
      return MakeModel(argv[2], argc >= 4 ? std::stol(argv[3]) : 50, argc >= 5 && std::string(argv[4]) == "missing");
    }
    if (argc >= 4 && std::string(argv[1]) == "compare") return Compare(argv[2], argv[3], 1e-13);
    if (argc >= 6 && std::string(argv[1]) == "check-serial") return CheckSerial(argv[2], argv[3], argv[4], argv[5]);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  }
  MPI_Init(&argc, &argv);
  int code = 1;
  try {
    code = RunChecks();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    MPI_Abort(MPI_COMM_WORLD, 2);
  }
  MPI_Finalize();
  return code;
}
