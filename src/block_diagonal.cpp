// The coupled-subsystem model and the one-step covariance updates of the block-diagonal, banded and
// full filters (004 eqs. (3)-(17)). Steady state, Prop. 2.2 and the identical-subsystem reduction are
// in block_diagonal_analysis.cpp.
#include <algorithm>
#include <cmath>
#include <type_traits>

#include "kfx/block_diagonal.hpp"
#include "kfx/error.hpp"
#include "kfx/simulation.hpp"
#include "kfx/validation.hpp"

#include "block_diagonal_internal.hpp"  // the range-based passes defined at the end of this file

namespace kfx {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace {

// Small per-block matrices live on the stack (no allocation per block) up to 8 x 8.
constexpr int kMaxSmall = 8;
using Small = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxSmall, kMaxSmall>;
// Subsystems per chunk: the chunk's r-wide temporaries stay in cache (about 8 nb r doubles).
constexpr Index kChunk = 256;

std::string Dims(Index a, Index b) { return std::to_string(a) + "x" + std::to_string(b); }

void RequireStepShapes(const CoupledStep& s, const std::string& label) {
  const Index c = s.F.rows();
  if (c == 0 || s.F.cols() % c != 0) {
    throw Error(label + "F: expected c x (n c) packed blocks with c >= 1, got " + Dims(s.F.rows(), s.F.cols()));
  }
  const Index n = s.F.cols() / c, d = s.H.rows(), r = s.G.cols();
  RequireShape(label + "H", s.H, d, n * c);
  if (d == 0) throw Error(label + "H: expected d >= 1 measurement rows per subsystem, got 0");
  RequireShape(label + "V", s.V, c, n * c);
  RequireShape(label + "R", s.R, d, n * d);
  RequireShape(label + "G", s.G, n * c, r);
  RequireShape(label + "U", s.U, r, r);
}

void RequirePackedCovariance(const std::string& name, const MatrixXd& P, Index c, Index n) {
  RequireShape(name, P, c, n * c);
}

// Raw access to block i of a packed matrix with `rows` rows and blocks `cols` wide.
inline Eigen::Map<const MatrixXd> BlockOf(const MatrixXd& m, Index i, Index cols) {
  return Eigen::Map<const MatrixXd>(m.data() + i * cols * m.rows(), m.rows(), cols);
}
inline Eigen::Map<MatrixXd> BlockOf(MatrixXd& m, Index i, Index cols) {
  return Eigen::Map<MatrixXd>(m.data() + i * cols * m.rows(), m.rows(), cols);
}

// dst(i a + p, j) = sum_q blocks_i(p, q) src(i b + q, j) for subsystems [i0, i0 + nb): a column
// sweep (contiguous in both) of blockdiag(blocks) * src. blocks is packed a x (n b). A, B > 0 fix
// the block shape at compile time (the common small cases), 0 takes it from the arguments.
template <int A, int B>
void BlockRowsTimesImpl(const double* bl, Index a_rt, Index b_rt, Index nb, const double* src, Index src_ld,
                        double* dst, Index dst_ld, Index cols) {
  const Index a = A > 0 ? A : a_rt, b = B > 0 ? B : b_rt;
  for (Index j = 0; j < cols; ++j) {
    const double* s = src + j * src_ld;
    double* t = dst + j * dst_ld;
    for (Index i = 0; i < nb; ++i) {
      const double* m = bl + i * a * b;  // column-major a x b
      const double* si = s + i * b;
      double* ti = t + i * a;
      for (Index p = 0; p < a; ++p) {
        double acc = 0.0;
        for (Index q = 0; q < b; ++q) acc += m[q * a + p] * si[q];
        ti[p] = acc;
      }
    }
  }
}

void BlockRowsTimes(const MatrixXd& blocks, Index b, Index i0, Index nb, const double* src, Index src_ld, double* dst,
                    Index dst_ld, Index cols) {
  const Index a = blocks.rows();
  const double* bl = blocks.data() + i0 * a * b;
  if (a == 1 && b == 1) return BlockRowsTimesImpl<1, 1>(bl, a, b, nb, src, src_ld, dst, dst_ld, cols);
  if (a == 1 && b == 2) return BlockRowsTimesImpl<1, 2>(bl, a, b, nb, src, src_ld, dst, dst_ld, cols);
  if (a == 2 && b == 1) return BlockRowsTimesImpl<2, 1>(bl, a, b, nb, src, src_ld, dst, dst_ld, cols);
  if (a == 2 && b == 2) return BlockRowsTimesImpl<2, 2>(bl, a, b, nb, src, src_ld, dst, dst_ld, cols);
  BlockRowsTimesImpl<0, 0>(bl, a, b, nb, src, src_ld, dst, dst_ld, cols);
}

// The per-subsystem Kalman step shared by the block-diagonal filter (Q = V: eqs. (9), (14), (15))
// and the banded filter (Q = D{V + G U G^T}) for subsystems [i0, i1): L = F P F^T + Q,
// M = H L H^T + R = R_c^T R_c (Cholesky), J = L H^T M^{-1} (the banded gain), P_out = L - J H L,
// and, when asked for, R_c^{-1} (d x d upper triangular, so M^{-1} = R_c^{-1} R_c^{-T}) into
// rinv[(i - i0) d^2 ...]. MatC, MatD, MatDC are c x c, d x d, d x c types: fixed-size for the
// common shapes, stack-allocated dynamic for c, d <= 8, heap-allocated beyond.
template <typename MatC, typename MatD, typename MatDC>
void SubsystemKalmanSteps(const CoupledStep& s, const MatrixXd& Pp, const MatrixXd& Q, Index i0, Index i1, double* rinv,
                          MatrixXd& J, MatrixXd& P_out) {
  const Index c = s.c(), d = s.d();
  for (Index i = i0; i < i1; ++i) {
    const MatC F = BlockOf(s.F, i, c);
    const MatDC H = BlockOf(s.H, i, c);
    MatC L = F * MatC(BlockOf(Pp, i, c)) * F.transpose() + MatC(BlockOf(Q, i, c));
    L = (0.5 * (L + L.transpose())).eval();
    const MatDC HL = H * L;
    const MatD M = HL * H.transpose() + MatD(BlockOf(s.R, i, d));
    MatDC Jt;  // M^{-1} H L = J^T
    if constexpr (MatD::RowsAtCompileTime == 1) {
      const double m = M(0, 0);
      if (!(m > 0.0) || !std::isfinite(m)) {
        throw NumericalError("M (block " + std::to_string(i) + "): H L H^T + R is not positive");
      }
      Jt = HL / m;
      if (rinv) rinv[i - i0] = 1.0 / std::sqrt(m);
      BlockOf(J, i, d) = Jt.transpose();
      const MatC A = L - Jt.transpose() * HL;
      BlockOf(P_out, i, c) = 0.5 * (A + A.transpose());
      continue;
    }
    const Eigen::LLT<MatD> llt(M);
    if (llt.info() != Eigen::Success) {
      throw NumericalError("M (block " + std::to_string(i) + "): H L H^T + R is not positive definite");
    }
    if constexpr (MatD::RowsAtCompileTime != Eigen::Dynamic) {
      // Fixed d <= 4: closed-form inverse of the Cholesky factor (no BLAS call per subsystem; with
      // EIGEN_USE_BLAS every triangular solve would be a DTRSM call with its locking overhead).
      const MatD Rinv = MatD(llt.matrixL()).inverse().transpose();  // R_c^{-1}, M = R_c^T R_c
      Jt.noalias() = Rinv * (Rinv.transpose() * HL);
      if (rinv) Eigen::Map<MatD>(rinv + (i - i0) * d * d) = Rinv;
    } else {
      Jt = llt.solve(HL);
      if (rinv) {
        Eigen::Map<MatrixXd>(rinv + (i - i0) * d * d, d, d) = llt.matrixU().solve(MatD::Identity(d, d));
      }
    }
    BlockOf(J, i, d) = Jt.transpose();
    const MatC A = L - Jt.transpose() * HL;
    BlockOf(P_out, i, c) = 0.5 * (A + A.transpose());
  }
}

void SubsystemKalmanSteps(const CoupledStep& s, const MatrixXd& Pp, const MatrixXd& Q, Index i0, Index i1, double* rinv,
                          MatrixXd& J, MatrixXd& P_out) {
  using Eigen::Matrix;
  const Index c = s.c(), d = s.d();
  if (c == 1 && d == 1) {
    SubsystemKalmanSteps<Matrix<double, 1, 1>, Matrix<double, 1, 1>, Matrix<double, 1, 1>>(s, Pp, Q, i0, i1, rinv, J,
                                                                                           P_out);
  } else if (c == 2 && d == 1) {
    SubsystemKalmanSteps<Eigen::Matrix2d, Matrix<double, 1, 1>, Matrix<double, 1, 2>>(s, Pp, Q, i0, i1, rinv, J, P_out);
  } else if (c == 2 && d == 2) {
    SubsystemKalmanSteps<Eigen::Matrix2d, Eigen::Matrix2d, Eigen::Matrix2d>(s, Pp, Q, i0, i1, rinv, J, P_out);
  } else if (c <= kMaxSmall && d <= kMaxSmall) {
    SubsystemKalmanSteps<Small, Small, Small>(s, Pp, Q, i0, i1, rinv, J, P_out);
  } else {
    SubsystemKalmanSteps<MatrixXd, MatrixXd, MatrixXd>(s, Pp, Q, i0, i1, rinv, J, P_out);
  }
}

// Pass 1 of the coupling terms for the subsystems of one chunk, in the transposed layout where each
// subsystem's r-vectors are contiguous (local block l, global i = i0 + l):
//   HG_i^T = G_i^T H_i^T (r x d),  Z_i^T = HG_i^T R_c^{-1} (so Z^T Z = HG^T M^{-1} HG, eq. (16)),
//   Y_i^T = Z_i^T R_c^{-T} = (M^{-1} H G)_i^T,  E_i^T = HG_i^T J_i^T - G_i^T (eq. (10) minus G).
// C, D > 0 fix c and d at compile time (the common shapes), Eigen::Dynamic takes them from c, d.
// Yt and Et may be null (not stored).
template <int C, int D>
void CouplingPass1(Index c, Index d, Index r, Index nb, const double* H, const double* J, const double* rinv,
                   const double* Gt, double* hg_buf, double* Zt, double* Yt, double* Et) {
  using Eigen::Map;
  using Eigen::Matrix;
  using MatRC = Matrix<double, Eigen::Dynamic, C>;
  using MatRD = Matrix<double, Eigen::Dynamic, D>;
  Map<MatRD> hg(hg_buf, r, d);
  for (Index l = 0; l < nb; ++l) {
    const Map<const MatRC> g(Gt + l * r * c, r, c);
    const Map<const Matrix<double, D, C>> h(H + l * d * c, d, c);
    const Map<const Matrix<double, C, D>> j(J + l * c * d, c, d);
    const Map<const Matrix<double, D, D>> ri(rinv + l * d * d, d, d);
    hg.noalias() = g.lazyProduct(h.transpose());
    Map<MatRD> zt(Zt + l * r * d, r, d);
    zt.noalias() = hg.lazyProduct(ri);
    if (Yt) Map<MatRD>(Yt + l * r * d, r, d).noalias() = zt.lazyProduct(ri.transpose());
    if (Et) {
      Map<MatRC> et(Et + l * r * c, r, c);
      et.noalias() = hg.lazyProduct(j.transpose());
      et -= g;
    }
  }
}

// E_i^T = HG_i^T J_i^T - G_i^T (eq. (10) minus G) for d = 1, from z = HG_i^T (r) and G_i^T (r x c).
inline void ScalarMeasurementEt(Index c, Index r, const double* jl, const double* z, const double* g, double* e) {
  for (Index q = 0; q < c; ++q) {
    const double jq = jl[q];
    const double* gq = g + q * r;
    double* eq = e + q * r;
    for (Index t = 0; t < r; ++t) eq[t] = jq * z[t] - gq[t];
  }
}

// HG_i^T = G_i^T H_i^T (r) for d = 1, accumulated over the c states.
inline void ScalarMeasurementHG(Index c, Index r, const double* h, const double* g, double* z) {
  for (Index t = 0; t < r; ++t) z[t] = h[0] * g[t];
  for (Index q = 1; q < c; ++q) {
    const double hq = h[q];
    const double* gq = g + q * r;
    for (Index t = 0; t < r; ++t) z[t] += hq * gq[t];
  }
}

// Pass 1 for d = 1 (one measurement per subsystem, the common case) as plain loops along r, which
// the compiler vectorizes (src/CMakeLists.txt enables loop vectorization for this file); one call
// per chunk, not per subsystem. Block l of Gt / Et is r x c, of Zt / Yt r x 1; h_q, J_q and
// M^{-1/2} come from the packed 1 x c, c x 1 and 1 x 1 blocks. Yt and Et may be null (not stored).
void CouplingPass1ScalarMeasurement(Index c, Index r, Index nb, const double* H, const double* J, const double* rinv,
                                    const double* Gt, double* Zt, double* Yt, double* Et) {
  for (Index l = 0; l < nb; ++l) {
    const double* g = Gt + l * r * c;
    double* z = Zt + l * r;
    ScalarMeasurementHG(c, r, H + l * c, g, z);
    if (Et) ScalarMeasurementEt(c, r, J + l * c, z, g, Et + l * r * c);
    const double ri = rinv[l];
    for (Index t = 0; t < r; ++t) z[t] *= ri;  // Z^T = HG^T M^{-1/2}
    if (Yt) {
      double* y = Yt + l * r;
      for (Index t = 0; t < r; ++t) y[t] = ri * z[t];
    }
  }
}

// E^T of one chunk (r x nb c) recomputed from G^T, H and J, for pass 2 when E was not stored.
template <int C, int D>
void CouplingEt(Index c, Index d, Index r, Index nb, const double* H, const double* J, const double* Gt, double* hg_buf,
                double* Et) {
  if (d == 1) {
    for (Index l = 0; l < nb; ++l) {
      const double* g = Gt + l * r * c;
      ScalarMeasurementHG(c, r, H + l * c, g, hg_buf);
      ScalarMeasurementEt(c, r, J + l * c, hg_buf, g, Et + l * r * c);
    }
    return;
  }
  using Eigen::Map;
  using Eigen::Matrix;
  using MatRC = Matrix<double, Eigen::Dynamic, C>;
  using MatRD = Matrix<double, Eigen::Dynamic, D>;
  Map<MatRD> hg(hg_buf, r, d);
  for (Index l = 0; l < nb; ++l) {
    const Map<const MatRC> g(Gt + l * r * c, r, c);
    const Map<const Matrix<double, D, C>> h(H + l * d * c, d, c);
    const Map<const Matrix<double, C, D>> j(J + l * c * d, c, d);
    hg.noalias() = g.lazyProduct(h.transpose());
    Map<MatRC> et(Et + l * r * c, r, c);
    et.noalias() = hg.lazyProduct(j.transpose());
    et -= g;
  }
}

// G_chunk^T (r x m) from rows [row0, row0 + m) of G ((n c) x r, column-major), in tiles of 8 rows so
// that both the reads and the writes stay within a few cache lines (measured faster than one pass
// per column at n = 1e3 .. 1e6).
void TransposeRows(const MatrixXd& G, Index row0, Index m, double* Gt) {
  const Index r = G.cols(), ld = G.rows();
  constexpr Index kTile = 8;
  for (Index i = 0; i < m; i += kTile) {
    const Index ib = std::min(kTile, m - i);
    for (Index j = 0; j < r; ++j) {
      const double* src = G.data() + j * ld + row0 + i;
      for (Index q = 0; q < ib; ++q) Gt[(i + q) * r + j] = src[q];
    }
  }
}

// Pass 2 for one chunk, all subsystems at once: P_i(a, b) += <column a, column b of W_i^T>, as
// column sums over strided column sets (vectorized along k).
void CouplingPass2Strided(Index c, Index k, Index nb, const double* Wt, double* P) {
  using Eigen::InnerStride;
  using Eigen::OuterStride;
  using Cols = Eigen::Map<const MatrixXd, 0, OuterStride<>>;
  using RowOut = Eigen::Map<Eigen::RowVectorXd, 0, InnerStride<>>;
  for (Index a = 0; a < c; ++a) {
    const Cols wa(Wt + a * k, k, nb, OuterStride<>(k * c));
    for (Index b = 0; b <= a; ++b) {
      const Cols wb(Wt + b * k, k, nb, OuterStride<>(k * c));
      RowOut pab(P + b * c + a, nb, InnerStride<>(c * c));
      pab += (wa.array() * wb.array()).matrix().colwise().sum();
      if (b != a) RowOut(P + a * c + b, nb, InnerStride<>(c * c)) = pab;
    }
  }
}

// Pass 2 for one chunk: P_i += W_i W_i^T with W_i^T the k x c block l of Wt (eq. (8) with
// C_2 = C_1, C_3 = -C_1 and C_1 = Fc Fc^T, W = E Fc).
template <int C>
void CouplingPass2(Index c, Index k, Index nb, const double* Wt, double* P) {
  using Eigen::Map;
  using Eigen::Matrix;
  for (Index l = 0; l < nb; ++l) {
    const Map<const Matrix<double, Eigen::Dynamic, C>> w(Wt + l * k * c, k, c);
    Map<Matrix<double, C, C>> Pi(P + l * c * c, c, c);
    Pi.noalias() += w.transpose().lazyProduct(w);
  }
}

}  // namespace

// ---- Model -----------------------------------------------------------------------------------------

CoupledStep MakeIdenticalCoupledStep(Index n, const MatrixXd& F, const MatrixXd& H, const MatrixXd& V,
                                     const MatrixXd& R, const MatrixXd& g, const MatrixXd& U) {
  if (n < 1) throw Error("n: expected at least 1 subsystem, got " + std::to_string(n));
  RequireSquare("F", F);
  const Index c = F.rows();
  RequireShape("H", H, -1, c);
  RequireShape("V", V, c, c);
  RequireShape("R", R, H.rows(), H.rows());
  RequireShape("g", g, c, -1);
  RequireShape("U", U, g.cols(), g.cols());
  CoupledStep s;
  s.F = F.replicate(1, n);
  s.H = H.replicate(1, n);
  s.V = V.replicate(1, n);
  s.R = R.replicate(1, n);
  s.G = g.replicate(n, 1);
  s.U = U;
  return s;
}

void ValidateCoupledStep(const CoupledStep& s, Index n, Index c, Index d, Index r, const std::string& label) {
  RequireShape(label + "F", s.F, c, n * c);
  RequireShape(label + "H", s.H, d, n * c);
  RequireShape(label + "V", s.V, c, n * c);
  RequireShape(label + "R", s.R, d, n * d);
  RequireShape(label + "G", s.G, n * c, r);
  RequireShape(label + "U", s.U, r, r);
  RequireFinite(label + "F", s.F);
  RequireFinite(label + "H", s.H);
  RequireFinite(label + "G", s.G);
  RequirePositiveSemidefinite(label + "U", s.U);
  for (Index i = 0; i < n; ++i) {
    const std::string b = " (block " + std::to_string(i) + ")";
    RequirePositiveSemidefinite(label + "V" + b, s.V.middleCols(i * c, c));
    RequirePositiveDefinite(label + "R" + b, s.R.middleCols(i * d, d));
  }
}

CoupledSystem::CoupledSystem(CoupledStep step, VectorXd m0, MatrixXd P0_blocks)
    : kind_(detail::ScheduleKind::kInvariant), m0_(std::move(m0)), P0_(std::move(P0_blocks)) {
  RequireStepShapes(step, "");
  n_ = step.n(), c_ = step.c(), d_ = step.d(), r_ = step.r();
  ValidateCoupledStep(step, n_, c_, d_, r_);
  steps_.push_back(std::make_shared<const CoupledStep>(std::move(step)));
  ValidatePrior();
}

CoupledSystem::CoupledSystem(std::vector<CoupledStep> steps, VectorXd m0, MatrixXd P0_blocks)
    : kind_(detail::ScheduleKind::kSequence), m0_(std::move(m0)), P0_(std::move(P0_blocks)) {
  if (steps.empty()) throw Error("steps: expected at least one step");
  RequireStepShapes(steps[0], "step 1: ");
  n_ = steps[0].n(), c_ = steps[0].c(), d_ = steps[0].d(), r_ = steps[0].r();
  for (size_t k = 0; k < steps.size(); ++k) {
    ValidateCoupledStep(steps[k], n_, c_, d_, r_, "step " + std::to_string(k + 1) + ": ");
    steps_.push_back(std::make_shared<const CoupledStep>(std::move(steps[k])));
  }
  horizon_ = static_cast<int>(steps_.size());
  ValidatePrior();
}

CoupledSystem::CoupledSystem(Index n, Index c, Index d, Index r, StepFunction function, VectorXd m0, MatrixXd P0_blocks,
                             int horizon)
    : kind_(detail::ScheduleKind::kFunction),
      n_(n),
      c_(c),
      d_(d),
      r_(r),
      horizon_(horizon),
      function_(std::move(function)),
      m0_(std::move(m0)),
      P0_(std::move(P0_blocks)) {
  if (n < 1 || c < 1 || d < 1 || r < 0) {
    throw Error("n, c, d, r: expected n, c, d >= 1 and r >= 0, got " + std::to_string(n) + ", " + std::to_string(c) +
                ", " + std::to_string(d) + ", " + std::to_string(r));
  }
  if (!function_) throw Error("function: expected a step callback");
  ValidatePrior();
}

void CoupledSystem::ValidatePrior() const {
  RequireVector("m0", m0_, n_ * c_);
  RequireFinite("m0", m0_);
  RequirePackedCovariance("P0", P0_, c_, n_);
  for (Index i = 0; i < n_; ++i) {
    RequirePositiveSemidefinite("P0 (block " + std::to_string(i) + ")", P0_.middleCols(i * c_, c_));
  }
}

std::shared_ptr<const CoupledStep> CoupledSystem::step(int k) const {
  return detail::StepAt<CoupledStep>(
      k, kind_, horizon_, steps_, function_,
      [this](const CoupledStep& s, const std::string& label) { ValidateCoupledStep(s, n_, c_, d_, r_, label); },
      "step");
}

int CoupledSystem::ResolveSteps(int steps) const {
  if (steps < 0) {
    if (horizon_ < 0) throw Error("steps: expected a number of steps (the system has no horizon)");
    return horizon_;
  }
  if (horizon_ >= 0 && steps > horizon_) {
    throw Error("steps: expected at most " + std::to_string(horizon_) + " steps (the system's horizon), got " +
                std::to_string(steps));
  }
  return steps;
}

// ---- Packed helpers --------------------------------------------------------------------------------

MatrixXd BlockDiagonalToDense(const MatrixXd& blocks, Index block_cols) {
  if (block_cols < 1 || blocks.cols() % block_cols != 0) {
    throw Error("blocks: expected a x (n b) packed blocks with b = " + std::to_string(block_cols) + ", got " +
                Dims(blocks.rows(), blocks.cols()));
  }
  const Index a = blocks.rows(), n = blocks.cols() / block_cols;
  MatrixXd dense = MatrixXd::Zero(n * a, n * block_cols);
  for (Index i = 0; i < n; ++i) {
    dense.block(i * a, i * block_cols, a, block_cols) = blocks.middleCols(i * block_cols, block_cols);
  }
  return dense;
}

MatrixXd DiagonalBlocks(const MatrixXd& M, Index a) {
  if (a < 1 || M.rows() != M.cols() || M.rows() % a != 0) {
    throw Error("M: expected a square matrix of size a multiple of " + std::to_string(a) + ", got " +
                Dims(M.rows(), M.cols()));
  }
  const Index n = M.rows() / a;
  MatrixXd blocks(a, n * a);
  for (Index i = 0; i < n; ++i) blocks.middleCols(i * a, a) = M.block(i * a, i * a, a, a);
  return blocks;
}

VectorXd BlockDiagonalApply(const MatrixXd& blocks, Index block_cols, const VectorXd& x) {
  if (block_cols < 1 || blocks.cols() % block_cols != 0) {
    throw Error("blocks: expected packed blocks " + std::to_string(block_cols) + " wide, got " +
                Dims(blocks.rows(), blocks.cols()));
  }
  RequireVector("x", x, blocks.cols());
  const Index n = blocks.cols() / block_cols;
  VectorXd y(n * blocks.rows());
  BlockRowsTimes(blocks, block_cols, 0, n, x.data(), x.size(), y.data(), y.size(), 1);
  return y;
}

ModelStep ToDenseStep(const CoupledStep& s) {
  RequireStepShapes(s, "");
  const Index c = s.c();
  MatrixXd Q = BlockDiagonalToDense(s.V, c);
  if (s.r() > 0) Q.noalias() += s.G * s.U * s.G.transpose();
  Symmetrize(Q);
  return MakeStep(BlockDiagonalToDense(s.F, c), BlockDiagonalToDense(s.H, c), std::move(Q),
                  BlockDiagonalToDense(s.R, s.d()));
}

Model ToDenseModel(const CoupledSystem& system) {
  MatrixXd P0 = BlockDiagonalToDense(system.P0_blocks(), system.c());
  if (system.time_invariant()) return Model(ToDenseStep(*system.step(1)), system.m0(), std::move(P0));
  return Model(
      system.state_dim(), system.meas_dim(), [system](int k) { return ToDenseStep(*system.step(k)); }, system.m0(),
      std::move(P0), system.horizon());
}

// ---- The block-diagonal step, eqs. (8)-(17) --------------------------------------------------------

VectorXd BlockDiagonalGain::Apply(const VectorXd& innovation) const {
  const Index c = J.rows(), nd = Yt.cols();
  RequireVector("innovation", innovation, nd);
  VectorXd out(Et.cols());
  const Index n = Et.cols() / std::max<Index>(c, 1);
  BlockRowsTimes(J, n > 0 ? nd / n : 0, 0, n, innovation.data(), nd, out.data(), out.size(), 1);
  if (Et.rows() > 0) out.noalias() -= Et.transpose() * (C1 * (Yt * innovation));
  return out;
}

VectorXd BlockDiagonalGain::CouplingMean(const VectorXd& innovation) const {
  RequireVector("innovation", innovation, Yt.cols());
  return C1 * (Yt * innovation);
}

MatrixXd BlockDiagonalGain::ToDense() const {
  const Index c = J.rows(), n = Et.cols() / std::max<Index>(c, 1);
  const Index d = n > 0 ? Yt.cols() / n : 0;
  MatrixXd K = BlockDiagonalToDense(J, d);
  if (Et.rows() > 0) K.noalias() -= Et.transpose() * C1 * Yt;
  return K;
}

BlockDiagonalCovarianceStep BlockDiagonalCovarianceUpdate(const CoupledStep& s, const MatrixXd& Pp) {
  BlockDiagonalCovarianceStep out;
  BlockDiagonalCovarianceUpdate(s, Pp, &out);
  return out;
}

namespace {

// The estimate update folded into the covariance passes (the running filter): on entry x = F x_prev
// and nu is the innovation (length n d); on exit x = F x_prev + K nu (eq. (7)) and mu_u = C_1 Y^T nu.
struct EstimateFold {
  const double* nu;
  double* x;
  VectorXd* mu_u;
};

// Eqs. (8)-(17) over all subsystems, through the range passes below (the distributed filter runs the
// same passes per slice): BlockDiagonalCovarianceUpdate stores the gain (E^T, Y^T: O(n r) doubles);
// CoupledFilter does not, and has K nu applied inside the passes. Without the stored gain each
// subsystem's data are streamed twice per step (G twice, 2 x 8 c r bytes) instead of about six times,
// which is what keeps the step linear in n once the arrays leave the cache.
void BlockDiagonalUpdate(const CoupledStep& s, const MatrixXd& Pp, BlockDiagonalCovarianceStep& out, bool store_gain,
                         const EstimateFold* est) {
  const Index n = s.n(), r = s.r();
  detail::BlockDiagonalWorkspace ws;
  detail::BlockDiagonalResize(s, store_gain, &out);
  MatrixXd N = MatrixXd::Zero(r, r);
  VectorXd ytnu = VectorXd::Zero(est ? r : 0);
  detail::BlockDiagonalPass1(s, Pp, 0, n, est ? est->nu : nullptr, &ws, &out, &N, est ? &ytnu : nullptr);
  N.triangularView<Eigen::StrictlyUpper>() = N.transpose();
  MatrixXd FcT(0, r);
  if (r > 0)
    FcT = detail::BlockDiagonalFactor(s.U, N, &out.gain.C1);
  else
    out.gain.C1.resize(0, 0);
  VectorXd v;
  if (est) {
    v.noalias() = out.gain.C1 * ytnu;  // mu_u = C_1 Y^T nu (after eq. (17), -C_3 = C_1)
    *est->mu_u = v;
  }
  detail::BlockDiagonalPass2(s, FcT, 0, n, est ? est->nu : nullptr, est ? &v : nullptr, est ? est->x : nullptr, &ws,
                             &out);
}

}  // namespace

void BlockDiagonalCovarianceUpdate(const CoupledStep& s, const MatrixXd& Pp, BlockDiagonalCovarianceStep* result) {
  KFX_ASSERT(result != nullptr);
  if (&Pp == &result->P_filt) throw Error("P_prev: must not alias the output's P_filt");
  RequireStepShapes(s, "");
  RequirePackedCovariance("P_prev", Pp, s.c(), s.n());
  BlockDiagonalUpdate(s, Pp, *result, /*store_gain=*/true, nullptr);  // reuses the caller's storage
}

DenseGainCovarianceStep NaiveBlockDiagonalCovarianceUpdate(const CoupledStep& s, const MatrixXd& Pp) {
  RequireStepShapes(s, "");
  const Index c = s.c();
  RequirePackedCovariance("P_prev", Pp, c, s.n());
  const ModelStep dense = ToDenseStep(s);
  // (3) P~_{k|k-1} = F P~ F^T + V + G U G^T
  MatrixXd P = dense.A * BlockDiagonalToDense(Pp, c) * dense.A.transpose() + dense.Q;
  Symmetrize(P);
  // (4) S = H P H^T + R, (5) K = P H^T S^{-1}
  const MatrixXd PHt = P * dense.C.transpose();
  const MatrixXd S = dense.C * PHt + dense.R;
  Eigen::LLT<MatrixXd> llt(S);
  if (llt.info() != Eigen::Success) throw NumericalError("S: H P H^T + R is not positive definite");
  DenseGainCovarianceStep out;
  out.K = llt.solve(PHt.transpose()).transpose();
  // (6) P~_{k|k} = D{(I - K H) P~_{k|k-1}}
  MatrixXd Pf = P - out.K * dense.C * P;
  Symmetrize(Pf);
  out.P_filt = DiagonalBlocks(Pf, c);
  return out;
}

// ---- The banded step ---------------------------------------------------------------------------------

MatrixXd BandedProcessNoise(const CoupledStep& s) {
  RequireStepShapes(s, "");
  const Index n = s.n(), c = s.c(), r = s.r();
  MatrixXd Q = s.V;
  if (r == 0) return Q;
  const MatrixXd GS = s.G * PsdFactor(s.U);  // (n c) x k
  for (Index i = 0; i < n; ++i) {
    BlockOf(Q, i, c).noalias() += GS.middleRows(i * c, c) * GS.middleRows(i * c, c).transpose();
  }
  return Q;
}

BandedCovarianceStep BandedCovarianceUpdate(const CoupledStep& s, const MatrixXd& Pp) {
  return BandedCovarianceUpdate(s, Pp, BandedProcessNoise(s));
}

BandedCovarianceStep BandedCovarianceUpdate(const CoupledStep& s, const MatrixXd& Pp, const MatrixXd& Qb) {
  RequireStepShapes(s, "");
  const Index n = s.n(), c = s.c(), d = s.d();
  RequirePackedCovariance("P_prev", Pp, c, n);
  RequirePackedCovariance("Q_blocks", Qb, c, n);
  BandedCovarianceStep out;
  out.P_filt.resize(c, n * c);
  out.K.resize(c, n * d);
  SubsystemKalmanSteps(s, Pp, Qb, 0, n, nullptr, out.K, out.P_filt);
  return out;
}

// ---- The full Kalman filter on the stacked system ----------------------------------------------------

VectorXd FullCovarianceStep::Apply(const VectorXd& innovation) const {
  RequireVector("innovation", innovation, HP.rows());
  return HP.transpose() * S.solve(innovation);
}

MatrixXd FullCovarianceStep::ToDense() const { return S.solve(HP).transpose(); }

FullCovarianceStep FullCovarianceUpdate(const CoupledStep& s, const MatrixXd& Pprev) {
  RequireStepShapes(s, "");
  const Index n = s.n(), c = s.c(), d = s.d(), N = n * c;
  RequireShape("P_prev", Pprev, N, N);
  FullCovarianceStep out;
  // Predict: P = F P F^T + blockdiag(V) + G U G^T with block-diagonal F (left, then right).
  MatrixXd P(N, N);
  for (Index i = 0; i < n; ++i) P.middleRows(i * c, c).noalias() = BlockOf(s.F, i, c) * Pprev.middleRows(i * c, c);
  MatrixXd P2(N, N);
  for (Index i = 0; i < n; ++i)
    P2.middleCols(i * c, c).noalias() = P.middleCols(i * c, c) * BlockOf(s.F, i, c).transpose();
  P = std::move(P2);
  for (Index i = 0; i < n; ++i) P.block(i * c, i * c, c, c) += BlockOf(s.V, i, c);
  if (s.r() > 0) {
    const MatrixXd GS = s.G * PsdFactor(s.U);
    P.selfadjointView<Eigen::Lower>().rankUpdate(GS);
  }
  P.triangularView<Eigen::StrictlyUpper>() = P.transpose();
  // Update: HP = blockdiag(H) P, S = HP H^T + blockdiag(R), P_filt = P - HP^T S^{-1} HP.
  out.HP.resize(n * d, N);
  for (Index i = 0; i < n; ++i) out.HP.middleRows(i * d, d).noalias() = BlockOf(s.H, i, c) * P.middleRows(i * c, c);
  MatrixXd S(n * d, n * d);
  for (Index j = 0; j < n; ++j)
    S.middleCols(j * d, d).noalias() = out.HP.middleCols(j * c, c) * BlockOf(s.H, j, c).transpose();
  for (Index i = 0; i < n; ++i) S.block(i * d, i * d, d, d) += BlockOf(s.R, i, d);
  S = 0.5 * (S + S.transpose()).eval();
  out.S.compute(S);
  if (out.S.info() != Eigen::Success) throw NumericalError("S: H P H^T + R is not positive definite");
  MatrixXd W = out.S.matrixL().solve(out.HP);  // L^{-1} H P
  P.selfadjointView<Eigen::Lower>().rankUpdate(W.transpose(), -1.0);
  P.triangularView<Eigen::StrictlyUpper>() = P.transpose();
  out.P_filt = std::move(P);
  return out;
}

// ---- Online part -----------------------------------------------------------------------------------

VectorXd CoupledPropagate(const CoupledStep& s, const VectorXd& x_prev) {
  return BlockDiagonalApply(s.F, s.c(), x_prev);
}

VectorXd CoupledPredictMeasurement(const CoupledStep& s, const VectorXd& x_prev) {
  return BlockDiagonalApply(s.H, s.c(), CoupledPropagate(s, x_prev));
}

const char* ToString(CoupledFilterKind kind) {
  switch (kind) {
    case CoupledFilterKind::kBlockDiagonal:
      return "block-diagonal";
    case CoupledFilterKind::kBlockDiagonalNaive:
      return "block-diagonal (naive)";
    case CoupledFilterKind::kBanded:
      return "banded";
    case CoupledFilterKind::kFull:
      return "full";
  }
  return "?";
}

CoupledFilter::CoupledFilter(CoupledFilterKind kind, VectorXd x0, const MatrixXd& P0_blocks)
    : kind_(kind), c_(P0_blocks.rows()), x_(std::move(x0)) {
  if (c_ < 1 || P0_blocks.cols() % c_ != 0) {
    throw Error("P0: expected c x (n c) packed blocks, got " + Dims(P0_blocks.rows(), P0_blocks.cols()));
  }
  RequireVector("x0", x_, P0_blocks.cols());
  RequireFinite("x0", x_);
  RequireFinite("P0", P0_blocks);
  P_ = kind == CoupledFilterKind::kFull ? BlockDiagonalToDense(P0_blocks, c_) : P0_blocks;
}

void CoupledFilter::Step(const CoupledStep& s, const VectorXd& y) {
  RequireVector("y", y, s.n() * s.d());
  RequireFinite("y", y);
  CheckStep(s);
  VectorXd x_pred = CoupledPropagate(s, x_);
  const VectorXd nu = y - BlockDiagonalApply(s.H, s.c(), x_pred);
  Update(s, nu, std::move(x_pred));
}

void CoupledFilter::CheckStep(const CoupledStep& s) const {
  RequireStepShapes(s, "");
  if (s.c() != c_ || s.n() * s.c() != x_.size()) {
    throw Error("step: expected " + std::to_string(x_.size() / c_) + " subsystems of " + std::to_string(c_) +
                " states, got " + std::to_string(s.n()) + " of " + std::to_string(s.c()));
  }
}

void CoupledFilter::StepWithInnovation(const CoupledStep& s, const VectorXd& nu) {
  CheckStep(s);
  RequireVector("innovation", nu, s.n() * s.d());
  Update(s, nu, CoupledPropagate(s, x_));
}

void CoupledFilter::Update(const CoupledStep& s, const VectorXd& nu, VectorXd x) {
  switch (kind_) {
    case CoupledFilterKind::kBlockDiagonal: {
      // The covariance passes apply the gain as they go (no separate passes over E and Y for K nu and
      // mu_u; work_'s buffers are reused from step to step). The gain is stored: recomputing E from G
      // in pass 2 (store_gain = false, what the distributed slices do to save memory) measured slower
      // here at every n from 1e3 to 1e6.
      RequirePackedCovariance("P", P_, s.c(), s.n());
      const EstimateFold fold{nu.data(), x.data(), &mu_u_};
      BlockDiagonalUpdate(s, P_, work_, /*store_gain=*/true, &fold);
      sigma_u_ = work_.gain.C1;
      P_.swap(work_.P_filt);
      break;
    }
    case CoupledFilterKind::kBlockDiagonalNaive: {
      DenseGainCovarianceStep st = NaiveBlockDiagonalCovarianceUpdate(s, P_);
      x += st.K * nu;
      // The posterior of u from the same quantities as the fast form (eq. after (17)).
      const BlockDiagonalCovarianceStep fast = BlockDiagonalCovarianceUpdate(s, P_);
      mu_u_ = fast.gain.CouplingMean(nu);
      sigma_u_ = fast.gain.C1;
      P_ = std::move(st.P_filt);
      break;
    }
    case CoupledFilterKind::kBanded: {
      BandedCovarianceStep st = BandedCovarianceUpdate(s, P_);
      x += BlockDiagonalApply(st.K, s.d(), nu);
      P_ = std::move(st.P_filt);
      break;
    }
    case CoupledFilterKind::kFull: {
      FullCovarianceStep st = FullCovarianceUpdate(s, P_);
      x += st.Apply(nu);
      P_ = std::move(st.P_filt);
      break;
    }
  }
  x_ = std::move(x);
}

CoupledRun RunCoupledFilter(const CoupledSystem& system, CoupledFilterKind kind, const TimeSeries& y,
                            const ProgressCallback& progress) {
  if (y.cols() != system.meas_dim()) {
    throw Error("y: expected " + std::to_string(system.meas_dim()) + " columns (n d), got " + std::to_string(y.cols()));
  }
  const int T = system.ResolveSteps(static_cast<int>(y.rows()));
  CoupledFilter filter(kind, system.m0(), system.P0_blocks());
  CoupledRun run;
  run.x_filt.resize(T + 1, system.state_dim());
  run.x_filt.row(0) = system.m0().transpose();
  const bool coupling = kind == CoupledFilterKind::kBlockDiagonal || kind == CoupledFilterKind::kBlockDiagonalNaive;
  if (coupling) run.coupling.resize(T, system.r());
  run.trace.resize(T + 1);
  auto trace = [&](const MatrixXd& P) {
    if (kind == CoupledFilterKind::kFull) return P.trace();
    double t = 0;
    for (Index i = 0; i < P.cols() / system.c(); ++i) t += P.middleCols(i * system.c(), system.c()).trace();
    return t;
  };
  run.trace(0) = trace(filter.P());
  for (int k = 1; k <= T; ++k) {
    filter.Step(*system.step(k), y.row(k - 1).transpose());
    run.x_filt.row(k) = filter.x().transpose();
    if (coupling) run.coupling.row(k - 1) = filter.coupling_mean().transpose();
    run.trace(k) = trace(filter.P());
    if (progress) progress(k, T);
  }
  return run;
}

LinearFilter CoupledFilterAsLinearFilter(const CoupledSystem& system, CoupledFilterKind kind, int steps) {
  const int T = system.ResolveSteps(steps);
  std::vector<LinearFilterStep> out;
  out.reserve(static_cast<size_t>(T));
  MatrixXd P =
      kind == CoupledFilterKind::kFull ? BlockDiagonalToDense(system.P0_blocks(), system.c()) : system.P0_blocks();
  for (int k = 1; k <= T; ++k) {
    const auto s = system.step(k);
    MatrixXd K;
    switch (kind) {
      case CoupledFilterKind::kBlockDiagonal: {
        auto st = BlockDiagonalCovarianceUpdate(*s, P);
        K = st.gain.ToDense();
        P = std::move(st.P_filt);
        break;
      }
      case CoupledFilterKind::kBlockDiagonalNaive: {
        auto st = NaiveBlockDiagonalCovarianceUpdate(*s, P);
        K = std::move(st.K);
        P = std::move(st.P_filt);
        break;
      }
      case CoupledFilterKind::kBanded: {
        auto st = BandedCovarianceUpdate(*s, P);
        K = BlockDiagonalToDense(st.K, s->d());
        P = std::move(st.P_filt);
        break;
      }
      case CoupledFilterKind::kFull: {
        auto st = FullCovarianceUpdate(*s, P);
        K = st.ToDense();
        P = std::move(st.P_filt);
        break;
      }
    }
    const MatrixXd F = BlockDiagonalToDense(s->F, s->c()), H = BlockDiagonalToDense(s->H, s->c());
    LinearFilterStep fs;
    fs.Phi = F - K * (H * F);
    fs.K = std::move(K);
    out.push_back(std::move(fs));
  }
  return LinearFilter(std::move(out), system.m0());
}

CoupledTrajectory SimulateCoupled(const CoupledSystem& system, int steps, std::uint64_t seed) {
  const int T = system.ResolveSteps(steps);
  const Index n = system.n(), c = system.c(), d = system.d(), r = system.r();
  Rng rng(seed);
  CoupledTrajectory tr;
  tr.x.resize(T + 1, n * c);
  tr.y.resize(T, n * d);
  tr.u.resize(T, r);
  VectorXd x(n * c);
  for (Index i = 0; i < n; ++i) {
    x.segment(i * c, c) =
        system.m0().segment(i * c, c) + PsdFactor(system.P0_blocks().middleCols(i * c, c)) * rng.Normal(c);
  }
  tr.x.row(0) = x.transpose();
  for (int k = 1; k <= T; ++k) {
    const auto s = system.step(k);
    const VectorXd u = PsdFactor(s->U) * rng.Normal(r);
    VectorXd xn = CoupledPropagate(*s, x);
    if (r > 0) xn.noalias() += s->G * u;
    VectorXd yk(n * d);
    for (Index i = 0; i < n; ++i) {
      xn.segment(i * c, c) += PsdFactor(BlockOf(s->V, i, c)) * rng.Normal(c);
    }
    yk = BlockDiagonalApply(s->H, c, xn);
    for (Index i = 0; i < n; ++i) yk.segment(i * d, d) += PsdFactor(BlockOf(s->R, i, d)) * rng.Normal(d);
    x = std::move(xn);
    tr.x.row(k) = x.transpose();
    tr.y.row(k - 1) = yk.transpose();
    tr.u.row(k - 1) = u.transpose();
  }
  return tr;
}

}  // namespace kfx

// ---- Range-based passes for the distributed filter (src/block_diagonal_internal.hpp) -----------------
// The same kernels and chunking as BlockDiagonalCovarianceUpdate above, over a range of subsystems.

namespace kfx::detail {

namespace {
template <typename Body>
void DispatchShapes(Index c, Index d, Body&& body) {
  using One = std::integral_constant<int, 1>;
  using Two = std::integral_constant<int, 2>;
  using Dyn = std::integral_constant<int, Eigen::Dynamic>;
  if (c == 2 && d == 1) {
    body(Two{}, One{});
  } else if (c == 1 && d == 1) {
    body(One{}, One{});
  } else if (c == 2 && d == 2) {
    body(Two{}, Two{});
  } else {
    body(Dyn{}, Dyn{});
  }
}
}  // namespace

void BlockDiagonalResize(const CoupledStep& s, bool store_gain, BlockDiagonalCovarianceStep* out) {
  const Index n = s.n(), c = s.c(), d = s.d(), r = s.r();
  out->P_filt.resize(c, n * c);
  out->gain.J.resize(c, n * d);
  out->gain.Yt.resize(r, store_gain ? n * d : 0);
  out->gain.Et.resize(r, store_gain ? n * c : 0);
}

void BlockDiagonalPass1(const CoupledStep& s, const MatrixXd& Pp, Index i0, Index i1, const double* nu,
                        BlockDiagonalWorkspace* w, BlockDiagonalCovarianceStep* out, MatrixXd* N, VectorXd* ytnu) {
  const Index c = s.c(), d = s.d(), r = s.r();
  BlockDiagonalGain& g = out->gain;
  if (r == 0) {
    SubsystemKalmanSteps(s, Pp, s.V, i0, i1, nullptr, g.J, out->P_filt);
    return;
  }
  const bool store_gain = g.Et.cols() > 0;
  const Index chunk = std::min(kChunk, std::max<Index>(i1 - i0, 1));
  if (w->Gt.rows() != r || w->Gt.cols() < chunk * c) w->Gt.resize(r, chunk * c);
  if (w->Zt.rows() != r || w->Zt.cols() < chunk * d) w->Zt.resize(r, chunk * d);
  w->hg.resize(r, d);
  if (w->rinv.size() < chunk * d * d) w->rinv.resize(chunk * d * d);
  if (nu && w->rnu.size() < chunk * d) w->rnu.resize(chunk * d);
  DispatchShapes(c, d, [&](auto C, auto D) {
    for (Index b0 = i0; b0 < i1; b0 += chunk) {
      const Index nb = std::min(chunk, i1 - b0);
      SubsystemKalmanSteps(s, Pp, s.V, b0, b0 + nb, w->rinv.data(), g.J, out->P_filt);
      TransposeRows(s.G, b0 * c, nb * c, w->Gt.data());
      double* yt = store_gain ? g.Yt.data() + b0 * d * r : nullptr;
      double* et = store_gain ? g.Et.data() + b0 * c * r : nullptr;
      if (d == 1) {
        CouplingPass1ScalarMeasurement(c, r, nb, s.H.data() + b0 * c, g.J.data() + b0 * c, w->rinv.data(), w->Gt.data(),
                                       w->Zt.data(), yt, et);
      } else {
        CouplingPass1<decltype(C)::value, decltype(D)::value>(c, d, r, nb, s.H.data() + b0 * d * c,
                                                              g.J.data() + b0 * c * d, w->rinv.data(), w->Gt.data(),
                                                              w->hg.data(), w->Zt.data(), yt, et);
      }
      N->selfadjointView<Eigen::Lower>().rankUpdate(w->Zt.leftCols(nb * d));
      if (nu) {  // Y^T nu = Z^T (R_c^{-T} nu); plain loops: per-subsystem Eigen products would be BLAS calls
        const double* ri = w->rinv.data();
        const double* nub = nu + b0 * d;
        double* rn = w->rnu.data();
        for (Index l = 0; l < nb; ++l) {
          for (Index a = 0; a < d; ++a) {
            double acc = 0.0;
            for (Index b = 0; b < d; ++b) acc += ri[l * d * d + a * d + b] * nub[l * d + b];  // (R_c^{-1})_{ba}
            rn[l * d + a] = acc;
          }
        }
        ytnu->noalias() += w->Zt.leftCols(nb * d) * w->rnu.head(nb * d);
      }
    }
  });
}

MatrixXd BlockDiagonalFactor(const MatrixXd& U, const MatrixXd& N, MatrixXd* C1) {
  // C_1 = (U^{-1} + N)^{-1} (eq. (11)) without inverting U (U may be singular, even 0):
  // with U = S S^T, C_1 = S (I + S^T N S)^{-1} S^T = Fc Fc^T, Fc = S L^{-T}, (I + S^T N S) = L L^T.
  const MatrixXd S = PsdFactor(U);
  MatrixXd T = MatrixXd::Identity(S.cols(), S.cols());
  T.noalias() += S.transpose() * N * S;
  Eigen::LLT<MatrixXd> tl(T);
  if (tl.info() != Eigen::Success) throw NumericalError("I + S^T N S: not positive definite (N is not PSD)");
  MatrixXd FcT = tl.matrixL().solve(S.transpose());  // k x r: Fc^T
  C1->noalias() = FcT.transpose() * FcT;
  return FcT;
}

void BlockDiagonalPass2(const CoupledStep& s, const MatrixXd& FcT, Index i0, Index i1, const double* nu,
                        const VectorXd* v, double* x, BlockDiagonalWorkspace* w, BlockDiagonalCovarianceStep* out) {
  const Index c = s.c(), d = s.d(), r = s.r(), k = FcT.rows();
  BlockDiagonalGain& g = out->gain;
  const bool store_gain = g.Et.cols() > 0;
  const Index chunk = std::min(kChunk, std::max<Index>(i1 - i0, 1));
  if (x && w->jnu.size() < chunk * c) w->jnu.resize(chunk * c);
  if (r > 0) {
    if (w->Wt.rows() != k || w->Wt.cols() < chunk * c) w->Wt.resize(k, chunk * c);
    if (!store_gain) {
      if (w->Gt.rows() != r || w->Gt.cols() < chunk * c) w->Gt.resize(r, chunk * c);
      if (w->Et.rows() != r || w->Et.cols() < chunk * c) w->Et.resize(r, chunk * c);
      w->hg.resize(r, d);
    }
  }
  DispatchShapes(c, d, [&](auto C, auto D) {
    for (Index b0 = i0; b0 < i1; b0 += chunk) {
      const Index nb = std::min(chunk, i1 - b0);
      if (x) {  // x_i += J_i nu_i
        BlockRowsTimes(g.J, d, b0, nb, nu + b0 * d, nb * d, w->jnu.data(), nb * c, 1);
        Eigen::Map<VectorXd>(x + b0 * c, nb * c) += w->jnu.head(nb * c);
      }
      if (r == 0) continue;
      const double* et = nullptr;
      if (store_gain) {
        et = g.Et.data() + b0 * c * r;
      } else {
        TransposeRows(s.G, b0 * c, nb * c, w->Gt.data());
        CouplingEt<decltype(C)::value, decltype(D)::value>(
            c, d, r, nb, s.H.data() + b0 * d * c, g.J.data() + b0 * c * d, w->Gt.data(), w->hg.data(), w->Et.data());
        et = w->Et.data();
      }
      const Eigen::Map<const MatrixXd> Etc(et, r, nb * c);
      w->Wt.leftCols(nb * c).noalias() = FcT * Etc;
      double* P = out->P_filt.data() + b0 * c * c;
      if (c <= 4) {
        CouplingPass2Strided(c, k, nb, w->Wt.data(), P);
      } else {
        CouplingPass2<Eigen::Dynamic>(c, k, nb, w->Wt.data(), P);
      }
      if (x) Eigen::Map<VectorXd>(x + b0 * c, nb * c).noalias() -= Etc.transpose() * *v;  // - E_i mu_u
    }
  });
}

}  // namespace kfx::detail
