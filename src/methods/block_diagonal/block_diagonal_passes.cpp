// The O(n r^2) step of 004's block-diagonal filter (eqs. (8)-(17)) as range passes over subsystems:
// pass 1, the coupling factor C_1 and pass 2 (block_diagonal_internal.hpp), and the portable kernels
// they run chunk by chunk (the reference the AVX2 kernels of block_diagonal_simd*.cpp are tested
// against). The whole-step driver is in block_diagonal_step.cpp, the distributed filter runs the same
// passes per slice. The hot loops of the filter are here: compiled with loop vectorization
// (CMakeLists.txt).
#include <algorithm>
#include <atomic>
#include <type_traits>
#include <vector>

#include "kfx/block_diagonal.hpp"
#include "kfx/error.hpp"
#include "kfx/simulation.hpp"
#include "methods/block_diagonal/block_diagonal_internal.hpp"
#include "methods/block_diagonal/block_diagonal_shared.hpp"
#include "methods/block_diagonal/block_diagonal_simd.hpp"

namespace kfx::detail {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace {
std::atomic<bool> specialized_kernels{true};
}  // namespace
bool SpecializedKernels() { return specialized_kernels.load(std::memory_order_relaxed); }
void SetBlockDiagonalSpecializedKernels(bool enabled) { specialized_kernels.store(enabled); }

namespace {

// Subsystems per chunk: the chunk's r-wide temporaries stay in cache (about 8 nb r doubles).
constexpr Index kChunk = 256;

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

}  // namespace

// dst = blockdiag(blocks_i) src for nb blocks a x b stored contiguously (column-major) from bl.
void BlockRowsTimesRaw(const double* bl, Index a, Index b, Index nb, const double* src, Index src_ld, double* dst,
                       Index dst_ld, Index cols) {
  if (SpecializedKernels()) {
    if (a == 1 && b == 1) return BlockRowsTimesImpl<1, 1>(bl, a, b, nb, src, src_ld, dst, dst_ld, cols);
    if (a == 1 && b == 2) return BlockRowsTimesImpl<1, 2>(bl, a, b, nb, src, src_ld, dst, dst_ld, cols);
    if (a == 2 && b == 1) return BlockRowsTimesImpl<2, 1>(bl, a, b, nb, src, src_ld, dst, dst_ld, cols);
    if (a == 2 && b == 2) return BlockRowsTimesImpl<2, 2>(bl, a, b, nb, src, src_ld, dst, dst_ld, cols);
  }
  BlockRowsTimesImpl<0, 0>(bl, a, b, nb, src, src_ld, dst, dst_ld, cols);
}

namespace {

// B_i = R_c^{-T} H_i (d x c) for nb subsystems, packed contiguously, from H_i (d x c, packed from h) and
// the Cholesky inverses R_c^{-1} (d x d, column-major, as SubsystemKalmanSteps writes them). Z_i =
// B_i G_i then gives Z^T Z = G^T H^T M^{-1} H G (eq. (16)), M = R_c^T R_c.
template <int C, int D>
void WhitenedMeasurementImpl(Index c_rt, Index d_rt, Index nb, const double* h, const double* rinv, double* B) {
  const Index c = C > 0 ? C : c_rt, d = D > 0 ? D : d_rt;
  if (d == 1) {
    for (Index l = 0; l < nb; ++l)
      for (Index q = 0; q < c; ++q) B[l * c + q] = rinv[l] * h[l * c + q];
    return;
  }
  for (Index l = 0; l < nb; ++l) {
    const double* ri = rinv + l * d * d;
    const double* hl = h + l * d * c;
    double* bl = B + l * d * c;
    for (Index q = 0; q < c; ++q)
      for (Index p = 0; p < d; ++p) {
        double acc = 0.0;
        for (Index a = 0; a <= p; ++a) acc += ri[p * d + a] * hl[q * d + a];  // (R_c^{-1})_{ap}, upper triangular
        bl[q * d + p] = acc;
      }
  }
}

// A_i = J_i H_i - I (c x c) for nb subsystems, packed contiguously: E_i = B_i - G_i = A_i G_i (eq. (10)
// minus G), so E never has to be formed or stored to apply it.
template <int C, int D>
void GainResidualImpl(Index c_rt, Index d_rt, Index nb, const double* j, const double* h, double* A) {
  const Index c = C > 0 ? C : c_rt, d = D > 0 ? D : d_rt;
  for (Index l = 0; l < nb; ++l) {
    const double* jl = j + l * c * d;
    const double* hl = h + l * d * c;
    double* al = A + l * c * c;
    for (Index q = 0; q < c; ++q)
      for (Index p = 0; p < c; ++p) {
        double acc = p == q ? -1.0 : 0.0;
        for (Index a = 0; a < d; ++a) acc += jl[a * c + p] * hl[q * d + a];
        al[q * c + p] = acc;
      }
  }
}

// The fixed-shape instances for the common (c, d) in {1, 2} x {1, 2}, else the generic one.
template <typename Body>
void DispatchSmall(Index c, Index d, Body&& body) {
  using One = std::integral_constant<int, 1>;
  using Two = std::integral_constant<int, 2>;
  using Gen = std::integral_constant<int, 0>;
  if (!SpecializedKernels()) return body(Gen{}, Gen{});
  if (c == 2 && d == 1) return body(Two{}, One{});
  if (c == 1 && d == 1) return body(One{}, One{});
  if (c == 2 && d == 2) return body(Two{}, Two{});
  if (c == 1 && d == 2) return body(One{}, Two{});
  body(Gen{}, Gen{});
}

void WhitenedMeasurement(Index c, Index d, Index nb, const double* h, const double* rinv, double* B) {
  DispatchSmall(c, d, [&](auto C, auto D) {
    WhitenedMeasurementImpl<decltype(C)::value, decltype(D)::value>(c, d, nb, h, rinv, B);
  });
}

void GainResidual(Index c, Index d, Index nb, const double* j, const double* h, double* A) {
  DispatchSmall(c, d,
                [&](auto C, auto D) { GainResidualImpl<decltype(C)::value, decltype(D)::value>(c, d, nb, j, h, A); });
}

// Gram blocks of W ((nb c) x k, column-major, leading dimension ldw): T_i = W_i W_i^T with W_i rows
// [i c, (i + 1) c). T is c x (nb c) scratch: T_i(a, b), a >= b, lands at T[(a - b) nb c + i c + b],
// the sum over columns t of w_j w_{j + delta} (j = i c + b, delta = a - b). For fixed C these sums
// run over blocks of 8 consecutive rows held in registers across all k columns (the loops vectorize;
// the few products that straddle two subsystems are not used); the generic version loops per
// subsystem.
template <int C>
void GramBlocksImpl(Index c_rt, Index k, Index nb, const double* W, Index ldw, double* T) {
  static_assert(C <= 4, "fixed-size Gram kernel for c <= 4");
  const Index c = C > 0 ? C : c_rt, m = nb * c;
  Index j0 = 0;
  if constexpr (C > 0) {
    constexpr Index kB = 8;
    using Rows = Eigen::Array<double, kB, 1>;  // fixed size: Eigen unrolls it into register packets
    for (; j0 + kB + C - 1 <= m; j0 += kB) {
      // Named accumulators (not an array) so that they stay in registers.
      Rows acc0 = Rows::Zero(), acc1 = Rows::Zero(), acc2 = Rows::Zero(), acc3 = Rows::Zero();
      for (Index t = 0; t < k; ++t) {
        const double* w = W + t * ldw + j0;
        const Rows w0 = Eigen::Map<const Rows>(w);
        acc0 += w0 * w0;
        if constexpr (C > 1) acc1 += w0 * Eigen::Map<const Rows>(w + 1);
        if constexpr (C > 2) acc2 += w0 * Eigen::Map<const Rows>(w + 2);
        if constexpr (C > 3) acc3 += w0 * Eigen::Map<const Rows>(w + 3);
      }
      Eigen::Map<Rows>(T + j0) = acc0;
      if constexpr (C > 1) Eigen::Map<Rows>(T + m + j0) = acc1;
      if constexpr (C > 2) Eigen::Map<Rows>(T + 2 * m + j0) = acc2;
      if constexpr (C > 3) Eigen::Map<Rows>(T + 3 * m + j0) = acc3;
    }
  }
  for (Index j = j0; j < m; ++j) {  // the rest (all of it in the generic version)
    const Index b = j % c;
    for (Index delta = 0; b + delta < c; ++delta) {
      double acc = 0.0;
      for (Index t = 0; t < k; ++t) acc += W[t * ldw + j] * W[t * ldw + j + delta];
      T[delta * m + j] = acc;
    }
  }
}

// P_i += A_i T_i A_i^T for nb subsystems, with T_i from GramBlocks (structure of arrays) and A_i packed
// c x c; the lower triangle is computed and mirrored, so P stays exactly symmetric.
template <int C>
void CongruenceSoAImpl(Index c_rt, Index nb, const double* A, const double* T, double* P) {
  const Index c = C > 0 ? C : c_rt;
  double stack_buf[C > 0 ? C * C : 1];
  std::vector<double> heap_buf(C > 0 ? 0 : c * c);
  double* tl = C > 0 ? stack_buf : heap_buf.data();
  for (Index l = 0; l < nb; ++l) {
    const double* a = A + l * c * c;
    for (Index i = 0; i < c; ++i)
      for (Index j = 0; j <= i; ++j) tl[j * c + i] = tl[i * c + j] = T[(i - j) * nb * c + l * c + j];
    double* p = P + l * c * c;
    for (Index i = 0; i < c; ++i)
      for (Index j = 0; j <= i; ++j) {
        double acc = 0.0;
        for (Index q = 0; q < c; ++q) {
          double at = 0.0;  // (A_i T_i)(i, q)
          for (Index s = 0; s < c; ++s) at += a[s * c + i] * tl[q * c + s];
          acc += at * a[q * c + j];
        }
        p[j * c + i] += acc;
        if (j != i) p[i * c + j] = p[j * c + i];
      }
  }
}

void GramBlocks(Index c, Index k, Index nb, const double* W, Index ldw, double* T) {
  if (SpecializedKernels()) {
    if (c == 1) return GramBlocksImpl<1>(c, k, nb, W, ldw, T);
    if (c == 2) return GramBlocksImpl<2>(c, k, nb, W, ldw, T);
    if (c == 3) return GramBlocksImpl<3>(c, k, nb, W, ldw, T);
    if (c == 4) return GramBlocksImpl<4>(c, k, nb, W, ldw, T);
  }
  GramBlocksImpl<0>(c, k, nb, W, ldw, T);
}

void CongruenceSoA(Index c, Index nb, const double* A, const double* T, double* P) {
  if (SpecializedKernels()) {
    if (c == 1) return CongruenceSoAImpl<1>(c, nb, A, T, P);
    if (c == 2) return CongruenceSoAImpl<2>(c, nb, A, T, P);
    if (c == 3) return CongruenceSoAImpl<3>(c, nb, A, T, P);
    if (c == 4) return CongruenceSoAImpl<4>(c, nb, A, T, P);
  }
  CongruenceSoAImpl<0>(c, nb, A, T, P);
}

}  // namespace

void BlockDiagonalResize(const CoupledStep& s, bool store_gain, BlockDiagonalCovarianceStep* out) {
  const Index n = s.n(), c = s.c(), d = s.d(), r = s.r();
  out->P_filt.resize(c, n * c);
  out->gain.J.resize(c, n * d);
  out->gain.Yt.resize(r, store_gain ? n * d : 0);
  out->gain.Et.resize(r, store_gain ? n * c : 0);
}

namespace {
// A workspace buffer of at least `size` doubles (kept across steps).
double* Buffer(VectorXd& v, Index size) {
  if (v.size() < size) v.resize(size);
  return v.data();
}
// Rows [row0, row0 + rows) of G, all r columns, in place (leading dimension n c).
using ConstStrided = Eigen::Map<const MatrixXd, 0, Eigen::OuterStride<>>;
ConstStrided GRows(const MatrixXd& G, Index row0, Index rows) {
  return ConstStrided(G.data() + row0, rows, G.cols(), Eigen::OuterStride<>(std::max<Index>(G.rows(), 1)));
}
}  // namespace

void BlockDiagonalPass1(const CoupledStep& s, const MatrixXd& Pp, Index i0, Index i1, const double* nu,
                        BlockDiagonalWorkspace* w, BlockDiagonalCovarianceStep* out, MatrixXd* N, VectorXd* ytnu,
                        const PredictFold* predict) {
  const Index c = s.c(), d = s.d(), r = s.r();
  KFX_ASSERT(predict == nullptr || nu == predict->nu);
  BlockDiagonalGain& g = out->gain;
  // x_pred = F x_prev, nu = y - H x_pred for subsystems [b0, b0 + nb).
  auto predict_chunk = [&](Index b0, Index nb) {
    if (!predict) return;
    double* xp = predict->x_pred + b0 * c;
    BlockRowsTimes(s.F, c, b0, nb, predict->x_prev + b0 * c, nb * c, xp, nb * c, 1);
    double* e = predict->nu + b0 * d;
    BlockRowsTimes(s.H, c, b0, nb, xp, nb * c, e, nb * d, 1);
    for (Index j = 0; j < nb * d; ++j) e[j] = predict->y[b0 * d + j] - e[j];
  };
  if (r == 0) {
    for (Index b0 = i0; b0 < i1; b0 += kChunk) predict_chunk(b0, std::min(kChunk, i1 - b0));
    SubsystemKalmanSteps(s, Pp, s.V, i0, i1, nullptr, g.J, out->P_filt);
    return;
  }
  const bool store_gain = g.Et.cols() > 0;
  const Index chunk = std::min(kChunk, std::max<Index>(i1 - i0, 1));
  double* rinv = Buffer(w->rinv, chunk * d * d);
  double* B = Buffer(w->B, chunk * d * c);
  double* Z = Buffer(w->Z, chunk * d * r);
  double* rnu = nu ? Buffer(w->rnu, chunk * d) : nullptr;
  // The AVX2 kernels fuse Z, Z^T Z and Y^T nu for c = 2, d <= 2 (Z itself is not kept).
  const bool simd = c == 2 && d <= 2 && !store_gain && SimdKernelsEnabled();
  if (simd) Z = Buffer(w->Z, chunk * d * r + 64);
  // R_c^{-T} nu of the chunk: Y^T nu = Z^T (R_c^{-T} nu).
  auto whitened_innovation = [&](Index b0, Index nb) {
    const double* nub = nu + b0 * d;
    for (Index l = 0; l < nb; ++l) {
      for (Index a = 0; a < d; ++a) {
        double acc = 0.0;
        for (Index b = 0; b <= a; ++b) acc += rinv[l * d * d + a * d + b] * nub[l * d + b];  // (R_c^{-1})_{ba}
        rnu[l * d + a] = acc;
      }
    }
  };
  for (Index b0 = i0; b0 < i1; b0 += chunk) {
    const Index nb = std::min(chunk, i1 - b0);
    predict_chunk(b0, nb);
    SubsystemKalmanSteps(s, Pp, s.V, b0, b0 + nb, rinv, g.J, out->P_filt);
    // Z = blockdiag(R_c^{-T} H_i) G_chunk ((nb d) x r), read from G in place, one column sweep.
    WhitenedMeasurement(c, d, nb, s.H.data() + b0 * d * c, rinv, B);
    const ConstStrided Gc = GRows(s.G, b0 * c, nb * c);
    if (simd) {
      if (nu) whitened_innovation(b0, nb);
      double* Nd = N->data();
      double* yd = ytnu ? ytnu->data() : nullptr;
      if (d == 1) {
        Pass1C2D1Avx2(nb, r, B, Gc.data(), Gc.outerStride(), nu ? rnu : nullptr, Nd, yd, Z);
      } else {
        Pass1C2D2Avx2(nb, r, B, Gc.data(), Gc.outerStride(), nu ? rnu : nullptr, Nd, yd, Z);
      }
      continue;
    }
    BlockRowsTimesRaw(B, d, c, nb, Gc.data(), Gc.outerStride(), Z, nb * d, r);
    const Eigen::Map<const MatrixXd> Zc(Z, nb * d, r);
    N->selfadjointView<Eigen::Lower>().rankUpdate(Zc.transpose());  // one DSYRK per chunk
    if (nu) {
      whitened_innovation(b0, nb);
      ytnu->noalias() += Zc.transpose() * Eigen::Map<const VectorXd>(rnu, nb * d);
    }
    if (store_gain) {
      // Y_i = M_i^{-1} H_i G_i = R_c^{-1} Z_i and E_i = A_i G_i, stored transposed (r x d, r x c blocks).
      double* Y = Buffer(w->Wt, nb * std::max(c, d) * r);
      BlockRowsTimesRaw(rinv, d, d, nb, Z, nb * d, Y, nb * d, r);
      g.Yt.middleCols(b0 * d, nb * d) = Eigen::Map<const MatrixXd>(Y, nb * d, r).transpose();
      double* A = Buffer(w->A, nb * c * c);
      GainResidual(c, d, nb, g.J.data() + b0 * c * d, s.H.data() + b0 * d * c, A);
      BlockRowsTimesRaw(A, c, c, nb, Gc.data(), Gc.outerStride(), Y, nb * c, r);
      g.Et.middleCols(b0 * c, nb * c) = Eigen::Map<const MatrixXd>(Y, nb * c, r).transpose();
    }
  }
}

CouplingFactor BlockDiagonalFactor(const MatrixXd& U, const MatrixXd& N, MatrixXd* C1) {
  // C_1 = (U^{-1} + N)^{-1} (eq. (11)) without inverting U (U may be singular, even 0):
  // with U = S S^T, C_1 = S (I + S^T N S)^{-1} S^T = F F^T, F = S L^{-T}, (I + S^T N S) = L L^T.
  // U's factor is kept from the last call on this thread (U is usually the same every step).
  thread_local MatrixXd U_last, S;
  if (U_last.rows() != U.rows() || U_last != U) {
    S = PsdFactor(U);
    U_last = U;
  }
  const Index k = S.cols();
  MatrixXd T = MatrixXd::Identity(k, k);
  const MatrixXd NS = N * S;
  T.noalias() += S.transpose() * NS;
  const Eigen::LLT<MatrixXd> tl(T);
  if (tl.info() != Eigen::Success) throw NumericalError("I + S^T N S: not positive definite (N is not PSD)");
  const MatrixXd FT = tl.matrixL().solve(S.transpose());  // k x r: F^T
  C1->noalias() = FT.transpose() * FT;
  // Pass 2 needs any factor of C_1; a lower trapezoidal one, C_1 = Ld Ld^T, makes W = G Ld cost half
  // the flops of G F: the Cholesky factor of C_1 or, when C_1 is singular (U is), the LQ factor of F
  // (F = Ld Q, from the QR of F^T).
  CouplingFactor f;
  const Eigen::LLT<MatrixXd> chol(*C1);
  if (chol.info() == Eigen::Success) {
    f.Ld = chol.matrixL();
  } else {
    const Eigen::HouseholderQR<MatrixXd> qr(FT);
    f.Ld = MatrixXd(qr.matrixQR().topRows(std::min(k, U.rows())).triangularView<Eigen::Upper>()).transpose();
  }
  f.FcT = f.Ld.transpose();
  return f;
}

namespace {
// The rest of pass 2 for c = 2, d = 1, fused per subsystem: A = J H - I, P_i += A T_i A^T (T_i from
// the Gram sums sq, cross) and, when x is given, x_i += J nu_i - A (G_i mu_u).
void FinishC2D1(Index nb, const double* J, const double* H, const double* sq, const double* cross, const double* nu,
                const double* gv, double* P, double* x) {
  for (Index l = 0; l < nb; ++l) {
    const double j0 = J[2 * l], j1 = J[2 * l + 1], h0 = H[2 * l], h1 = H[2 * l + 1];
    const double a00 = j0 * h0 - 1.0, a01 = j0 * h1, a10 = j1 * h0, a11 = j1 * h1 - 1.0;
    const double t00 = sq[2 * l], t11 = sq[2 * l + 1], t10 = cross[2 * l];
    // rows of A T
    const double b00 = a00 * t00 + a01 * t10, b01 = a00 * t10 + a01 * t11;
    const double b10 = a10 * t00 + a11 * t10, b11 = a10 * t10 + a11 * t11;
    double* p = P + 4 * l;
    p[0] += b00 * a00 + b01 * a01;
    const double off = b10 * a00 + b11 * a01;
    p[1] += off;
    p[2] = p[1];
    p[3] += b10 * a10 + b11 * a11;
    if (x) {
      const double e = nu[l], g0 = gv[2 * l], g1 = gv[2 * l + 1];
      x[2 * l] += j0 * e - (a00 * g0 + a01 * g1);
      x[2 * l + 1] += j1 * e - (a10 * g0 + a11 * g1);
    }
  }
}
}  // namespace

void BlockDiagonalPass2(const CoupledStep& s, const CouplingFactor& factor, Index i0, Index i1, const double* nu,
                        const VectorXd* v, double* x, BlockDiagonalWorkspace* w, BlockDiagonalCovarianceStep* out) {
  const Index c = s.c(), d = s.d(), r = s.r(), k = factor.FcT.rows();
  BlockDiagonalGain& g = out->gain;
  const Index chunk = std::min(kChunk, std::max<Index>(i1 - i0, 1));
  // The AVX2 kernel fuses W = G Fc (triangular Fc), its Gram blocks and G mu_u for c = 2.
  const bool simd = c == 2 && r > 0 && SimdKernelsEnabled();
  double* jnu = x ? Buffer(w->jnu, chunk * c) : nullptr;
  double* A = r > 0 ? Buffer(w->A, chunk * c * c) : nullptr;
  double* Wt = r > 0 && !simd ? Buffer(w->Wt, chunk * c * std::max<Index>(k, 1)) : nullptr;
  double* T = r > 0 ? Buffer(w->T, chunk * c * c) : nullptr;
  double* gv = x && r > 0 ? Buffer(w->gv, chunk * c) : nullptr;
  for (Index b0 = i0; b0 < i1; b0 += chunk) {
    const Index nb = std::min(chunk, i1 - b0);
    if (simd && d == 1) {
      const ConstStrided Gc = GRows(s.G, b0 * c, nb * c);
      Pass2C2Avx2(nb, r, factor.Ld.cols(), Gc.data(), Gc.outerStride(), factor.Ld.data(), x ? v->data() : nullptr, T,
                  T + nb * c, gv);
      FinishC2D1(nb, g.J.data() + b0 * c, s.H.data() + b0 * c, T, T + nb * c, x ? nu + b0 : nullptr, gv,
                 out->P_filt.data() + b0 * c * c, x ? x + b0 * c : nullptr);
      continue;
    }
    if (x) {  // x_i += J_i nu_i
      BlockRowsTimes(g.J, d, b0, nb, nu + b0 * d, nb * d, jnu, nb * c, 1);
      Eigen::Map<VectorXd>(x + b0 * c, nb * c) += Eigen::Map<const VectorXd>(jnu, nb * c);
    }
    if (r == 0) continue;
    // E_i = A_i G_i, so E_i C_1 E_i^T = A_i (G_i Fc)(G_i Fc)^T A_i^T (eq. (8) with C_2 = C_1,
    // C_3 = -C_1): W = G_chunk Fc straight from G, the Gram blocks T_i = W_i W_i^T, then
    // P_i += A_i T_i A_i^T.
    GainResidual(c, d, nb, g.J.data() + b0 * c * d, s.H.data() + b0 * d * c, A);
    const ConstStrided Gc = GRows(s.G, b0 * c, nb * c);
    if (simd) {  // T in GramBlocks' layout: T_i(0, 0), T_i(1, 1) at T[2 i + b], T_i(1, 0) at T[nb c + 2 i]
      Pass2C2Avx2(nb, r, factor.Ld.cols(), Gc.data(), Gc.outerStride(), factor.Ld.data(), x ? v->data() : nullptr, T,
                  T + nb * c, gv);
    } else {
      const int m = static_cast<int>(nb * c), nk = static_cast<int>(k), nr = static_cast<int>(r);
      const int ldg = static_cast<int>(Gc.outerStride()), ldf = static_cast<int>(std::max<Index>(k, 1));
      const double one = 1.0, zero = 0.0;
      if (k > 0) {
        dgemm_("N", "T", &m, &nk, &nr, &one, Gc.data(), &ldg, factor.FcT.data(), &ldf, &zero, Wt, &m);
        GramBlocks(c, k, nb, Wt, nb * c, T);
      } else {
        std::fill(T, T + nb * c * c, 0.0);
      }
      if (x) Eigen::Map<VectorXd>(gv, nb * c).noalias() = Gc * *v;
    }
    CongruenceSoA(c, nb, A, T, out->P_filt.data() + b0 * c * c);
    if (x) {  // x_i -= E_i mu_u = A_i (G_i mu_u)
      BlockRowsTimesRaw(A, c, c, nb, gv, nb * c, jnu, nb * c, 1);
      Eigen::Map<VectorXd>(x + b0 * c, nb * c) -= Eigen::Map<const VectorXd>(jnu, nb * c);
    }
  }
}

}  // namespace kfx::detail
