// Which rank holds which subsystems: the partition of n subsystems into contiguous ranges of whole
// granules balanced by cost, and the slice of a coupled step or system that a rank holds
// (include/kfx/distributed.hpp).
#include "kfx/distributed.hpp"

#include <algorithm>
#include <string>

#include "kfx/error.hpp"
#include "kfx/validation.hpp"

namespace kfx {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

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

namespace {

// Columns (rows) [first, first + count) of M. An empty M (r = 0 couplings, or d = 0) has a null data
// pointer that a block must not offset (UBSan's null-pointer offset; not a BLAS matter, so kfx's
// matrix-vector binding, src/base/eigen_gemv.hpp, does not make these two unnecessary).
MatrixXd MiddleCols(const MatrixXd& M, Index first, Index count) {
  if (M.size() == 0) return MatrixXd(M.rows(), count);
  return M.middleCols(first, count);
}
MatrixXd MiddleRows(const MatrixXd& M, Index first, Index count) {
  if (M.size() == 0) return MatrixXd(count, M.cols());
  return M.middleRows(first, count);
}

}  // namespace

CoupledStep SliceCoupledStep(const CoupledStep& s, Index first, Index count) {
  const Index n = s.n(), c = s.c(), d = s.d();
  if (first < 0 || count < 0 || first + count > n) {
    throw Error("slice: expected a range of subsystems within [0, " + std::to_string(n) + "), got [" +
                std::to_string(first) + ", " + std::to_string(first + count) + ")");
  }
  CoupledStep out;
  out.F = MiddleCols(s.F, first * c, count * c);
  out.H = MiddleCols(s.H, first * c, count * c);
  out.V = MiddleCols(s.V, first * c, count * c);
  out.R = MiddleCols(s.R, first * d, count * d);
  out.G = MiddleRows(s.G, first * c, count * c);
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

}  // namespace kfx
