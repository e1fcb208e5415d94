// FilterMany: n independent small Kalman filters (004's subsystems with U = 0), the "vectorise over
// pixels" case. The filters run in chunks of kLanes: a chunk's model blocks are copied once into
// structure-of-arrays scratch, its states stay in L1 over all T steps, and each step runs V filters at
// a time in vector registers, one filter per element (AVX-512, AVX2/FMA or SSE2, chosen at run time).
// Per filter and step the memory traffic is the measurement read and the estimate written: a whole
// chunk reads scalar measurements in place and writes estimates of c <= 2 in place (interleaved in
// registers); other shapes and a last, partial chunk go through small lane buffers.
#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "kfx/block_diagonal.hpp"
#include "kfx/error.hpp"
#include "kfx/validation.hpp"

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define KFX_MANY_X86 1
#else
#define KFX_MANY_X86 0
#endif

// Full unrolling of the fixed-size loops of the kernels (GCC at -O2 keeps them as loops).
#if defined(__clang__)
#define KFX_PRAGMA(x) _Pragma(#x)
#define KFX_UNROLL(n) KFX_PRAGMA(unroll n)
#elif defined(__GNUC__)
#define KFX_PRAGMA(x) _Pragma(#x)
#define KFX_UNROLL(n) KFX_PRAGMA(GCC unroll n)
#else
#define KFX_UNROLL(n)
#endif

namespace kfx {

using Eigen::Index;
using Eigen::MatrixXd;

namespace {

constexpr Index kLanes = 64;  // filters per chunk: model (C = 2, D = 1: 11 doubles) and state (6) in L1

// Block i of a packed a x (n b) matrix, or its only block when it holds one (the same for all filters).
const double* Block(const MatrixXd& m, Index i, Index b) {
  return m.cols() == b ? m.data() : m.data() + i * m.rows() * b;
}

// Chunk state and model in structure-of-arrays form: element e of lane j at [e * kLanes + j].
struct Lanes {
  std::vector<double> F, H, Q, R, x, P;
};

// Vectors of V doubles (GCC/Clang vector extensions): one filter per element, so that the whole step of
// V filters stays in registers. Loads and stores go through memcpy (no alignment assumed).
template <int V>
struct VecOf {
  typedef double type __attribute__((vector_size(8 * V)));  // (an alias template would drop the attribute)
};
template <int V>
using Vec = typename VecOf<V>::type;

// Load, Store and ChunkStep are always inlined into the kernels compiled for the CPU (target attributes
// below): the by-value vector ABI that -Wpsabi warns about never applies.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wpsabi"
template <int V>
[[gnu::always_inline]] inline Vec<V> Load(const double* p) {
  Vec<V> r;
  std::memcpy(&r, p, sizeof r);
  return r;
}

template <int V>
[[gnu::always_inline]] inline void Store(double* p, const Vec<V>& v) {
  std::memcpy(p, &v, sizeof v);
}

// Writes V filters' estimates x[0..C) (lane l of x[a]: filter l's component a) as out[l C + a]; C <= 2.
template <int C, int V>
[[gnu::always_inline]] inline void StoreInterleaved(double* out, const Vec<V>* x) {
  static_assert(C <= 2, "interleaved store for C <= 2");
  if constexpr (C == 1) {
    Store<V>(out, x[0]);
  } else if constexpr (V == 2) {
    Store<V>(out, __builtin_shufflevector(x[0], x[1], 0, 2));
    Store<V>(out + V, __builtin_shufflevector(x[0], x[1], 1, 3));
  } else if constexpr (V == 4) {
    Store<V>(out, __builtin_shufflevector(x[0], x[1], 0, 4, 1, 5));
    Store<V>(out + V, __builtin_shufflevector(x[0], x[1], 2, 6, 3, 7));
  } else {
    static_assert(V == 8, "V = 2, 4 or 8");
    Store<V>(out, __builtin_shufflevector(x[0], x[1], 0, 8, 1, 9, 2, 10, 3, 11));
    Store<V>(out + V, __builtin_shufflevector(x[0], x[1], 4, 12, 5, 13, 6, 14, 7, 15));
  }
}

// One step of the kLanes filters of a chunk, V at a time: predict, mask the missing components (as
// MaskMissingMeasurements: H row and R's correlations dropped, y 0), the standard update
// P = P_pred - U S^{-1} U^T with U = P_pred H^T (lower triangle, mirrored). y: the chunk's
// measurements (lane j's at y[j D + e], j < nb); xo: the chunk's estimates (lane j's at xo[j C + a]).
// Lanes nb..kLanes-1 of a last, partial chunk hold a valid filter (lane setup) and see a missing
// measurement; their results are not copied out.
template <int C, int D, int V>
[[gnu::always_inline]] inline void ChunkStep(Lanes& L, Index nb, const double* y, double* xo) {
  static_assert(D == 1 || D == 2, "fixed-shape update for D <= 2");
  static_assert(kLanes % V == 0, "whole vectors per chunk");
  using Vd = Vec<V>;
  static_assert(sizeof(Vd) == 8 * V, "a vector of V doubles");
  constexpr Index W = kLanes;
  const double* F = L.F.data();
  const double* H = L.H.data();
  const double* Q = L.Q.data();
  const double* R = L.R.data();
  double* X = L.x.data();
  double* P = L.P.data();
  alignas(64) double yl[D][W];
  alignas(64) double xl[C][W];
  const bool direct = D == 1 && nb == W;  // a whole chunk of scalar measurements: read y in place
  // A whole chunk of c <= 2 estimates: written in place (interleaved in registers).
  const bool direct_out = C <= 2 && nb == W;
  if (!direct) {
    for (int e = 0; e < D; ++e) {
      for (Index j = 0; j < nb; ++j) yl[e][j] = y[j * D + e];
      for (Index j = nb; j < W; ++j) yl[e][j] = std::numeric_limits<double>::quiet_NaN();
    }
  }
  const Vd zero = {}, one = zero + 1.0;
  KFX_UNROLL(1)
  for (Index j = 0; j < W; j += V) {
    Vd x[C], p[C][C], xp[C], fp[C][C], pp[C][C], f[C][C];  // f[a][b] = F(a, b); F column-major
    KFX_UNROLL(4)
    for (int a = 0; a < C; ++a) {
      x[a] = Load<V>(X + a * W + j);
      KFX_UNROLL(4)
      for (int b = 0; b < C; ++b) f[a][b] = Load<V>(F + (b * C + a) * W + j);
      KFX_UNROLL(4)
      for (int b = 0; b <= a; ++b) p[a][b] = p[b][a] = Load<V>(P + (a * C + b) * W + j);  // lower triangle kept
    }
    KFX_UNROLL(4)
    for (int a = 0; a < C; ++a) {
      Vd acc = f[a][0] * x[0];
      KFX_UNROLL(4)
      for (int b = 1; b < C; ++b) acc += f[a][b] * x[b];
      xp[a] = acc;
      KFX_UNROLL(4)
      for (int b = 0; b < C; ++b) {
        Vd t = f[a][0] * p[0][b];
        KFX_UNROLL(4)
        for (int q = 1; q < C; ++q) t += f[a][q] * p[q][b];
        fp[a][b] = t;
      }
    }
    KFX_UNROLL(4)
    for (int a = 0; a < C; ++a) {
      KFX_UNROLL(4)
      for (int b = 0; b <= a; ++b) {
        Vd acc = Load<V>(Q + (b * C + a) * W + j);
        KFX_UNROLL(4)
        for (int q = 0; q < C; ++q) acc += fp[a][q] * f[b][q];
        pp[a][b] = acc;
        pp[b][a] = acc;
      }
    }
    Vd h[D][C], ye[D], m[D];
    KFX_UNROLL(2)
    for (int e = 0; e < D; ++e) {
      const Vd v = Load<V>(direct ? y + j : yl[e] + j);
      const auto ok = v == v;  // NaN: missing
      m[e] = ok ? one : zero;
      ye[e] = ok ? v : zero;
      KFX_UNROLL(4)
      for (int q = 0; q < C; ++q) h[e][q] = m[e] * Load<V>(H + (q * D + e) * W + j);
    }
    Vd u[C][D], s[D][D], nu[D];
    KFX_UNROLL(4)
    for (int a = 0; a < C; ++a) {
      KFX_UNROLL(2)
      for (int e = 0; e < D; ++e) {
        Vd acc = pp[a][0] * h[e][0];
        KFX_UNROLL(4)
        for (int q = 1; q < C; ++q) acc += pp[a][q] * h[e][q];
        u[a][e] = acc;
      }
    }
    KFX_UNROLL(2)
    for (int e = 0; e < D; ++e) {
      Vd acc = ye[e];
      KFX_UNROLL(4)
      for (int q = 0; q < C; ++q) acc -= h[e][q] * xp[q];
      nu[e] = acc;
      KFX_UNROLL(2)
      for (int g = 0; g < D; ++g) {
        Vd sf = Load<V>(R + (g * D + e) * W + j);
        if (e != g) sf *= m[e] * m[g];
        KFX_UNROLL(4)
        for (int q = 0; q < C; ++q) sf += h[e][q] * u[q][g];
        s[e][g] = sf;
      }
    }
    Vd si[D][D];
    if constexpr (D == 1) {
      si[0][0] = one / s[0][0];
    } else {
      const Vd inv_det = one / (s[0][0] * s[1][1] - s[0][1] * s[1][0]);
      si[0][0] = s[1][1] * inv_det;
      si[1][1] = s[0][0] * inv_det;
      si[0][1] = si[1][0] = -0.5 * (s[0][1] + s[1][0]) * inv_det;
    }
    Vd k[C][D], xe[C];
    KFX_UNROLL(4)
    for (int a = 0; a < C; ++a) {
      KFX_UNROLL(2)
      for (int e = 0; e < D; ++e) {
        Vd acc = u[a][0] * si[0][e];
        KFX_UNROLL(2)
        for (int g = 1; g < D; ++g) acc += u[a][g] * si[g][e];
        k[a][e] = acc;
      }
      Vd xa = xp[a];
      KFX_UNROLL(2)
      for (int e = 0; e < D; ++e) xa += k[a][e] * nu[e];
      Store<V>(X + a * W + j, xa);
      if (direct_out) {
        xe[a] = xa;
      } else {
        Store<V>(xl[a] + j, xa);
      }
      KFX_UNROLL(4)
      for (int b = 0; b <= a; ++b) {
        Vd acc = pp[a][b];
        KFX_UNROLL(2)
        for (int e = 0; e < D; ++e) acc -= k[a][e] * u[b][e];
        Store<V>(P + (a * C + b) * W + j, acc);
      }
    }
    if constexpr (C <= 2) {
      if (direct_out) StoreInterleaved<C, V>(xo + j * C, xe);
    }
  }
  if (direct_out) return;
  for (Index j = 0; j < nb; ++j) {
    KFX_UNROLL(4)
    for (int a = 0; a < C; ++a) xo[j * C + a] = xl[a][j];
  }
}

#pragma GCC diagnostic pop

// All T steps of one chunk (the chunk's lanes already loaded), V filters per vector.
template <int C, int D, int V>
[[gnu::always_inline]] inline void ChunkRun(Lanes& L, Index i0, Index nb, const Eigen::Ref<const TimeSeries>& y,
                                            Eigen::Ref<TimeSeries>& xo) {
  for (Index t = 0; t < y.rows(); ++t)
    ChunkStep<C, D, V>(L, nb, y.data() + t * y.outerStride() + i0 * D, xo.data() + t * xo.outerStride() + i0 * C);
}

template <int C, int D>
void ChunkRunDefault(Lanes& L, Index i0, Index nb, const Eigen::Ref<const TimeSeries>& y, Eigen::Ref<TimeSeries>& xo) {
  ChunkRun<C, D, 2>(L, i0, nb, y, xo);  // SSE2 on x86-64
}
#if KFX_MANY_X86
template <int C, int D>
__attribute__((target("avx2,fma"))) void ChunkRunAvx2(Lanes& L, Index i0, Index nb,
                                                      const Eigen::Ref<const TimeSeries>& y,
                                                      Eigen::Ref<TimeSeries>& xo) {
  ChunkRun<C, D, 4>(L, i0, nb, y, xo);
}
template <int C, int D>
__attribute__((target("avx512f"))) void ChunkRunAvx512(Lanes& L, Index i0, Index nb,
                                                       const Eigen::Ref<const TimeSeries>& y,
                                                       Eigen::Ref<TimeSeries>& xo) {
  ChunkRun<C, D, 8>(L, i0, nb, y, xo);
}
#endif

using ChunkFn = void (*)(Lanes&, Index, Index, const Eigen::Ref<const TimeSeries>&, Eigen::Ref<TimeSeries>&);

template <int C, int D>
ChunkFn Pick() {
#if KFX_MANY_X86
  static const bool avx512 = __builtin_cpu_supports("avx512f");
  static const bool avx2 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  if (avx512) return &ChunkRunAvx512<C, D>;
  if (avx2) return &ChunkRunAvx2<C, D>;
#endif
  return &ChunkRunDefault<C, D>;
}

ChunkFn PickKernel(Index c, Index d) {
  if (d == 1) {
    if (c == 1) return Pick<1, 1>();
    if (c == 2) return Pick<2, 1>();
    if (c == 3) return Pick<3, 1>();
    if (c == 4) return Pick<4, 1>();
  } else if (d == 2) {
    if (c == 1) return Pick<1, 2>();
    if (c == 2) return Pick<2, 2>();
    if (c == 3) return Pick<3, 2>();
    if (c == 4) return Pick<4, 2>();
  }
  return nullptr;
}

// Copies block (a x b) of filter i into lane j of a structure-of-arrays buffer.
void ToLane(const double* block, Index size, Index j, std::vector<double>* lanes) {
  for (Index e = 0; e < size; ++e) (*lanes)[e * kLanes + j] = block[e];
}

// Any c, d: one filter at a time with Eigen's dynamic matrices (the same formulas).
void RunOneGeneric(const ManyFilterModel& m, Index i, const Eigen::Ref<const TimeSeries>& y, Eigen::Ref<TimeSeries>& xo,
                   MatrixXd* P_last) {
  const Index c = m.c(), d = m.d();
  const Eigen::Map<const MatrixXd> F(Block(m.F, i, c), c, c), H(Block(m.H, i, c), d, c), Q(Block(m.Q, i, c), c, c),
      R(Block(m.R, i, d), d, d);
  Eigen::VectorXd x = Eigen::Map<const Eigen::VectorXd>(m.x0.cols() == 1 ? m.x0.data() : m.x0.data() + i * c, c);
  MatrixXd P = Eigen::Map<const MatrixXd>(Block(m.P0, i, c), c, c);
  for (Index t = 0; t < y.rows(); ++t) {
    const Eigen::VectorXd xp = F * x;
    MatrixXd Pp = F * P * F.transpose() + Q;
    Symmetrize(Pp);
    Eigen::VectorXd yv = y.row(t).segment(i * d, d).transpose();
    MatrixXd Hm = H, Rm = R;
    for (Index e = 0; e < d; ++e) {
      if (!std::isnan(yv(e))) continue;
      yv(e) = 0.0;
      Hm.row(e).setZero();
      const double var = R(e, e);
      Rm.row(e).setZero();
      Rm.col(e).setZero();
      Rm(e, e) = var;
    }
    const MatrixXd U = Pp * Hm.transpose();
    Eigen::LLT<MatrixXd> S(Hm * U + Rm);
    const MatrixXd Kt = S.solve(U.transpose());
    x = xp + Kt.transpose() * (yv - Hm * xp);
    P = Pp - Kt.transpose() * U.transpose();
    Symmetrize(P);
    xo.row(t).segment(i * c, c) = x.transpose();
  }
  P_last->middleCols(i * c, c) = P;
}

// One block per filter, or one for all: a rows x b (shared) or rows x (n b) (per filter).
void RequireBlocks(const std::string& name, const MatrixXd& m, Index rows, Index b, Index n) {
  if (m.rows() != rows || (m.cols() != b && m.cols() != n * b)) {
    throw Error(name + ": expected " + ShapeString(rows, b) + " (all filters) or " + ShapeString(rows, n * b) +
                " (one block per filter), got " + ShapeString(m.rows(), m.cols()));
  }
  RequireFinite(name, m);
}

// Each block of Q and P0 symmetric PSD, of R symmetric PD (the message names the filter).
void RequireCovarianceBlocks(const std::string& name, const MatrixXd& m, Index b, bool definite) {
  const Index blocks = m.cols() / b;
  for (Index i = 0; i < blocks; ++i) {
    const Eigen::Map<const MatrixXd> blk(m.data() + i * b * b, b, b);
    const std::string label = blocks == 1 ? name : name + " (filter " + std::to_string(i) + ")";
    if (definite) {
      RequirePositiveDefinite(label, blk);
    } else {
      RequirePositiveSemidefinite(label, blk);
    }
  }
}

}  // namespace

void FilterMany(const ManyFilterModel& model, const Eigen::Ref<const TimeSeries>& y, Eigen::Ref<TimeSeries> x_filt,
                MatrixXd* P_filt) {
  KFX_ASSERT(P_filt != nullptr);
  const Index c = model.c(), d = model.d();
  if (c < 1) throw Error("F: expected c x c blocks with c >= 1, got " + ShapeString(model.F.rows(), model.F.cols()));
  if (d < 1) throw Error("H: expected d x c blocks with d >= 1, got " + ShapeString(model.H.rows(), model.H.cols()));
  if (y.cols() % d != 0 || y.cols() == 0) {
    throw Error("y: expected T x (n d) with d = " + std::to_string(d) + ", got " + ShapeString(y.rows(), y.cols()));
  }
  const Index n = y.cols() / d;
  if (model.x0.rows() != c || (model.x0.cols() != 1 && model.x0.cols() != n)) {
    throw Error("x0: expected " + ShapeString(c, 1) + " or " + ShapeString(c, n) + " (one column per filter), got " +
                ShapeString(model.x0.rows(), model.x0.cols()));
  }
  RequireFinite("x0", model.x0);
  RequireBlocks("F", model.F, c, c, n);
  RequireBlocks("H", model.H, d, c, n);
  RequireBlocks("Q", model.Q, c, c, n);
  RequireBlocks("R", model.R, d, d, n);
  RequireBlocks("P0", model.P0, c, c, n);
  RequireCovarianceBlocks("Q", model.Q, c, false);
  RequireCovarianceBlocks("R", model.R, d, true);
  RequireCovarianceBlocks("P0", model.P0, c, false);
  if (y.array().isInf().any()) throw Error("y: expected finite values or NaN (a missing measurement), got inf");
  if (x_filt.rows() != y.rows() || x_filt.cols() != n * c) {
    throw Error("x_filt: expected " + ShapeString(y.rows(), n * c) + ", got " +
                ShapeString(x_filt.rows(), x_filt.cols()));
  }
  P_filt->resize(c, n * c);
  const ChunkFn kernel = PickKernel(c, d);
  if (!kernel) {
    for (Index i = 0; i < n; ++i) RunOneGeneric(model, i, y, x_filt, P_filt);
    return;
  }
  Lanes L;
  for (auto* v : {&L.F, &L.Q, &L.P}) v->assign(c * c * kLanes, 0.0);
  L.H.assign(d * c * kLanes, 0.0);
  L.R.assign(d * d * kLanes, 0.0);
  for (Index e = 0; e < d; ++e)  // lanes past n hold R = I (a valid filter that sees no measurement)
    std::fill_n(L.R.begin() + (e * d + e) * kLanes, kLanes, 1.0);
  L.x.assign(c * kLanes, 0.0);
  for (Index i0 = 0; i0 < n; i0 += kLanes) {
    const Index nb = std::min(kLanes, n - i0);
    for (Index j = 0; j < nb; ++j) {
      const Index i = i0 + j;
      ToLane(Block(model.F, i, c), c * c, j, &L.F);
      ToLane(Block(model.H, i, c), d * c, j, &L.H);
      ToLane(Block(model.Q, i, c), c * c, j, &L.Q);
      ToLane(Block(model.R, i, d), d * d, j, &L.R);
      ToLane(Block(model.P0, i, c), c * c, j, &L.P);
      ToLane(model.x0.cols() == 1 ? model.x0.data() : model.x0.data() + i * c, c, j, &L.x);
    }
    kernel(L, i0, nb, y, x_filt);
    for (Index j = 0; j < nb; ++j)
      for (Index a = 0; a < c; ++a)  // the kernels keep the lower triangle (element (a, b) at a c + b, a >= b)
        for (Index b = 0; b <= a; ++b) {
          const double v = L.P[(a * c + b) * kLanes + j];
          (*P_filt)(a, (i0 + j) * c + b) = (*P_filt)(b, (i0 + j) * c + a) = v;
        }
  }
}

ManyFiltersRun FilterMany(const ManyFilterModel& model, const TimeSeries& y) {
  ManyFiltersRun run;
  const Index d = std::max<Index>(model.d(), 1), c = model.c();
  run.x_filt.resize(y.rows(), (y.cols() / d) * c);
  FilterMany(model, y, run.x_filt, &run.P_filt);
  return run;
}

}  // namespace kfx
