// `kfx blockdiag`: what one rank does with the job (read its slice of the coupled model and of the
// measurements, filter, write its slice of the output and, on rank 0, the metadata), and the reader of
// the output directory (include/kfx/distributed.hpp).
#include "kfx/distributed.hpp"

#include <chrono>
#include <exception>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "io/json_matrix.hpp"
#include "kfx/coupled_model_file.hpp"
#include "kfx/error.hpp"
#include "kfx/io.hpp"

namespace kfx {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;
namespace fs = std::filesystem;

namespace {

using json = detail::Json;

constexpr const char* kOutputFormat = "kfx-blockdiag-output";

std::string SliceName(const std::string& what, Index first, Index end) {
  return what + "." + std::to_string(first) + "-" + std::to_string(end) + ".npy";
}

bool IsOtherRanksFailure(const std::exception_ptr& error) {
  try {
    std::rethrow_exception(error);
  } catch (const std::exception& e) {
    return std::string(e.what()).find("on another rank") != std::string::npos;
  } catch (...) {
    return false;
  }
}

// Every rank learns which ranks failed (one reduction of a flag per rank), so no rank waits in a later
// reduction for a rank that has stopped, and only the lowest rank with an error of its own reports it: the
// others throw "failed on another rank", which the CLI does not print (one message for the whole job).
// Every rank calls this at the same points (after reading, after filtering, after writing, after the marker).
void AgreeOnFailure(const std::exception_ptr& error, int rank, int ranks, const Reducer& reduce) {
  std::vector<double> flags(2 * static_cast<size_t>(ranks), 0.0);
  const bool own = error && !IsOtherRanksFailure(error);
  if (error) flags[2 * static_cast<size_t>(rank)] = own ? 2.0 : 1.0;
  if (reduce) reduce(flags);
  int first_own = -1;
  bool any = false;
  for (int p = 0; p < ranks; ++p) {
    const double f = CompensatedValue(flags.data() + 2 * p);
    any = any || f != 0.0;
    if (f == 2.0 && first_own < 0) first_own = p;
  }
  if (error && (own ? first_own == rank : first_own < 0 && rank == 0)) std::rethrow_exception(error);
  if (any) throw Error("blockdiag: failed on another rank (see its message)");
}

// Runs `what`, keeping its exception for AgreeOnFailure.
template <typename F>
void Try(std::exception_ptr* error, F&& what) {
  if (*error) return;
  try {
    what();
  } catch (...) {
    *error = std::current_exception();
  }
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
    const double tol = job.steady_state_tolerance;
    if (!(tol >= 0.0 && tol <= 1e-2)) {
      throw Error("steady_state_tolerance: expected a value in [0, 1e-2], got " + std::to_string(tol));
    }
    if (tol > 0.0 && job.kind != CoupledFilterKind::kBlockDiagonal) {
      throw Error("steady_state_tolerance: the steady state is the block-diagonal filter's, not the banded one's");
    }
    if (tol > 0.0 && ranks > 1) {
      throw Error("steady_state_tolerance: the steady state runs in one process, got " + std::to_string(ranks) +
                  " ranks");
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
    // Rank 0 removes the previous run's metadata.json before any rank writes (the reduction in AgreeOnFailure
    // orders it before every write); the others only make sure the directory exists.
    OutputDirectory(job.out_dir, "metadata.json", rank == 0, "out_dir");
    if (sum.count > 0) {
      slice = std::make_unique<CoupledSystem>(LoadCoupledModelSlice(job.model, sum.first, sum.count));
      const NpyArray a = ReadNpySlice(job.data, 1, sum.first * h.d, sum.count * h.d);
      y = Eigen::Map<const TimeSeries>(a.data.data(), a.shape[0], a.shape[1]).topRows(sum.steps);
    }
  } catch (...) {
    error = std::current_exception();
  }
  AgreeOnFailure(error, rank, ranks, reduce);

  const auto t0 = std::chrono::steady_clock::now();
  SlicedRun run;
  try {
    if (sum.count > 0 && job.steady_state_tolerance > 0.0) {  // one rank: the whole model (checked above)
      CoupledFilterOptions options;
      options.steady_state_tolerance = job.steady_state_tolerance;
      CoupledRun whole = RunCoupledFilter(*slice, job.kind, y, options);
      run.x_filt = std::move(whole.x_filt);
      run.coupling = std::move(whole.coupling);
      run.P_filt = std::move(whole.P_filt);
      run.coupling_cov = std::move(whole.coupling_cov);
      sum.steady_state_steps = whole.steady_state_steps;
    } else if (sum.count > 0) {
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
  AgreeOnFailure(error, rank, ranks, reduce);

  const Index end = sum.first + sum.count, c = h.c;
  const fs::path dir(job.out_dir);
  Try(&error, [&] {
    if (!run.x_filt.allFinite() || !run.P_filt.allFinite()) {
      throw NumericalError("blockdiag: the estimates of subsystems [" + std::to_string(sum.first) + ", " +
                           std::to_string(end) + ") are not finite (the filter overflowed); nothing written");
    }
    WriteNpyMatrix((dir / SliceName("x_filt", sum.first, end)).string(), run.x_filt);
    std::vector<double> P(static_cast<size_t>(sum.count * c * c));
    for (Index i = 0; i < sum.count; ++i) {
      for (Index p = 0; p < c; ++p) {
        for (Index q = 0; q < c; ++q) P[static_cast<size_t>((i * c + p) * c + q)] = run.P_filt(p, i * c + q);
      }
    }
    WriteNpy((dir / SliceName("P_filt", sum.first, end)).string(), {sum.count, c, c}, P.data());
    if (rank == 0 && job.kind == CoupledFilterKind::kBlockDiagonal) {
      WriteNpyMatrix((dir / "coupling_mean.npy").string(), run.coupling);
      WriteNpyMatrix((dir / "coupling_cov.npy").string(), run.coupling_cov);
    }
  });
  // The completion marker only when every rank has written its slice.
  AgreeOnFailure(error, rank, ranks, reduce);
  Try(&error, [&] {
    if (rank != 0) return;
    json meta;
    meta["format"] = kOutputFormat;
    meta["filter"] = ToString(job.kind);
    meta["n"] = h.n, meta["c"] = h.c, meta["d"] = h.d, meta["r"] = h.r;
    meta["steps"] = sum.steps;
    meta["ranks"] = ranks;
    meta["granule"] = job.granule;
    meta["steady_state_tolerance"] = job.steady_state_tolerance;
    meta["steady_state_steps"] = sum.steady_state_steps;
    json slices = json::array();
    for (int p = 0; p < ranks; ++p) {
      const Index f = part.first(p), e = f + part.count(p);
      slices.push_back({{"first", f},
                        {"count", e - f},
                        {"x_filt", SliceName("x_filt", f, e)},
                        {"P_filt", SliceName("P_filt", f, e)}});
    }
    meta["slices"] = slices;
    OutputDirectory(job.out_dir, "metadata.json", /*owner=*/true, "out_dir").Commit(meta.dump(1));
  });
  AgreeOnFailure(error, rank, ranks, reduce);
  return sum;
}

TimeSeries ReadBlockDiagStates(const std::string& out_dir) {
  const fs::path dir(out_dir);
  const std::string path = (dir / "metadata.json").string();
  const json meta = detail::ReadJsonObject(path, kOutputFormat);
  detail::CheckJsonFormat(meta, path, kOutputFormat, /*required=*/true);
  const Index n = detail::JsonIndex(meta, path, "n", 1), c = detail::JsonIndex(meta, path, "c", 1);
  const Index T = detail::JsonIndex(meta, path, "steps", 0);
  TimeSeries x(T + 1, n * c);
  const auto slices = meta.find("slices");
  if (slices == meta.end() || !slices->is_array()) throw Error(path + ": field 'slices': expected an array");
  Index covered = 0;
  for (const json& sl : *slices) {
    // Each slice is checked field by field (a malformed one is a kfx::Error naming it, not a JSON exception).
    const auto file = sl.is_object() ? sl.find("x_filt") : sl.end();
    if (!sl.is_object() || file == sl.end() || !file->is_string()) {
      throw Error(path + ": slice " + sl.dump() + ": expected {\"first\", \"count\", \"x_filt\", ...}");
    }
    const Index f = detail::JsonIndex(sl, path, "first", 0), m = detail::JsonIndex(sl, path, "count", 0);
    if (f > n || m > n - f) {
      throw Error(path + ": slice " + sl.dump() + ": expected a range within the n = " + std::to_string(n) +
                  " subsystems");
    }
    covered += m;
    if (m == 0) continue;
    const MatrixXd part = ReadNpyMatrix((dir / file->get<std::string>()).string());
    if (part.rows() != T + 1 || part.cols() != m * c) {
      throw Error(path + ": slice " + sl.dump() + " does not match its file");
    }
    x.middleCols(f * c, m * c) = part;
  }
  if (covered != n) throw Error(path + ": expected slices covering the n = " + std::to_string(n) + " subsystems");
  return x;
}

}  // namespace kfx
