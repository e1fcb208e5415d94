// AVX2/FMA pass-2 kernel of the block-diagonal filter for c = 2 (src/block_diagonal_simd.hpp) and the
// run-time dispatch. Pass 1's kernel is in block_diagonal_simd_pass1.cpp.
#include "methods/block_diagonal/block_diagonal_simd.hpp"

#include <algorithm>
#include <vector>

#include "kfx/error.hpp"
#include "methods/block_diagonal/block_diagonal_internal.hpp"

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define KFX_SIMD_X86 1
#include <immintrin.h>
#else
#define KFX_SIMD_X86 0
#endif

namespace kfx::detail {

using Eigen::Index;

bool SimdKernelsEnabled() {
#if KFX_SIMD_X86
  static const bool cpu = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return cpu && SpecializedKernels();
#else
  return false;
#endif
}

#if KFX_SIMD_X86
namespace {

// Output columns per register tile: 6 columns x 2 row vectors = 12 accumulators (of 16 registers).
constexpr int kTileCols = 6;
// Prefetch distance along G's columns, in doubles (8 panels of 8 rows).
constexpr int kPrefetch = 32;

// One column tile (W output columns, coefficients packed row by row from t0) over RV row vectors
// (4 RV rows of G starting at row0). The first column is the gv column when has_v. Accumulates the
// Gram terms of the other columns into sq, cross (4 RV doubles each) and stores gv.
template <int W, int RV>
__attribute__((target("avx2,fma"))) inline void TileKernel(const double* const* cols, Index row0, int t0, int r,
                                                           const double* coef, bool has_v, double* sq, double* cross,
                                                           double* gv) {
  __m256d acc[RV][W];
#pragma GCC unroll 8
  for (int v = 0; v < RV; ++v)
#pragma GCC unroll 8
    for (int c = 0; c < W; ++c) acc[v][c] = _mm256_setzero_pd();
  for (int t = t0; t < r; ++t) {
    const double* col = cols[t] + row0;
    __m256d x[RV];
#pragma GCC unroll 8
    for (int v = 0; v < RV; ++v) x[v] = _mm256_loadu_pd(col + 4 * v);
    const double* ct = coef + (t - t0) * W;
#pragma GCC unroll 8
    for (int c = 0; c < W; ++c) {
      const __m256d b = _mm256_broadcast_sd(ct + c);
#pragma GCC unroll 8
      for (int v = 0; v < RV; ++v) acc[v][c] = _mm256_fmadd_pd(x[v], b, acc[v][c]);
    }
  }
#pragma GCC unroll 8
  for (int v = 0; v < RV; ++v) {
    __m256d s = _mm256_loadu_pd(sq + 4 * v), p = _mm256_loadu_pd(cross + 4 * v);
#pragma GCC unroll 8
    for (int c = 0; c < W; ++c) {
      if (c == 0 && has_v) {
        _mm256_storeu_pd(gv + 4 * v, acc[v][0]);
        continue;
      }
      s = _mm256_fmadd_pd(acc[v][c], acc[v][c], s);
      // Rows 2i and 2i + 1 share a 128-bit half: swapping within halves pairs each row with its partner.
      p = _mm256_fmadd_pd(acc[v][c], _mm256_permute_pd(acc[v][c], 0x5), p);
    }
    _mm256_storeu_pd(sq + 4 * v, s);
    _mm256_storeu_pd(cross + 4 * v, p);
  }
}

template <int RV>
__attribute__((target("avx2,fma"))) void PanelKernel(const double* const* cols, Index row0, int r,
                                                     const std::vector<int>& tile_t0,
                                                     const std::vector<int>& tile_width,
                                                     const std::vector<const double*>& tile_coef, bool has_v,
                                                     double* sq, double* cross, double* gv) {
#pragma GCC unroll 8
  for (int v = 0; v < RV; ++v) {
    _mm256_storeu_pd(sq + 4 * v, _mm256_setzero_pd());
    _mm256_storeu_pd(cross + 4 * v, _mm256_setzero_pd());
  }
  // G streams from memory for large n (r columns, one cache line each per panel): prefetch ahead.
  for (int t = 0; t < r; ++t) _mm_prefetch(reinterpret_cast<const char*>(cols[t] + row0 + kPrefetch), _MM_HINT_T0);
  for (std::size_t j = 0; j < tile_t0.size(); ++j) {
    const bool v0 = has_v && j == 0;
    const int t0 = tile_t0[j];
    const double* coef = tile_coef[j];
    switch (tile_width[j]) {
      case 6:
        TileKernel<6, RV>(cols, row0, t0, r, coef, v0, sq, cross, gv);
        break;
      case 5:
        TileKernel<5, RV>(cols, row0, t0, r, coef, v0, sq, cross, gv);
        break;
      case 4:
        TileKernel<4, RV>(cols, row0, t0, r, coef, v0, sq, cross, gv);
        break;
      case 3:
        TileKernel<3, RV>(cols, row0, t0, r, coef, v0, sq, cross, gv);
        break;
      case 2:
        TileKernel<2, RV>(cols, row0, t0, r, coef, v0, sq, cross, gv);
        break;
      default:
        TileKernel<1, RV>(cols, row0, t0, r, coef, v0, sq, cross, gv);
        break;
    }
  }
}

}  // namespace

__attribute__((target("avx2,fma"))) void Pass2C2Avx2(Index nb, Index r, Index k, const double* g, Index ldg,
                                                     const double* Ld, const double* v, double* sq, double* cross,
                                                     double* gv) {
  const Index m = 2 * nb;
  if (m == 0) return;
  const bool has_v = v != nullptr;
  const int ri = static_cast<int>(r);
  // Output columns: [gv (when v)], 0, ..., k - 1; column q needs t >= q (Ld is lower trapezoidal),
  // the gv column all t. Tiles of up to 6 consecutive columns start at their first column's t.
  thread_local std::vector<double> packed;
  thread_local std::vector<const double*> cols, tile_coef;
  thread_local std::vector<int> tile_t0, tile_width;
  const Index ncol = k + (has_v ? 1 : 0);
  packed.assign(static_cast<std::size_t>(std::max<Index>(ncol * r, 1)), 0.0);
  cols.resize(static_cast<std::size_t>(r));
  for (Index t = 0; t < r; ++t) cols[t] = g + t * ldg;
  tile_t0.clear();
  tile_width.clear();
  tile_coef.clear();
  Index used = 0;
  // Balanced widths (a narrow last tile costs nearly as much per call as a wide one).
  const Index ntiles = (ncol + kTileCols - 1) / kTileCols;
  for (Index j = 0, c0 = 0; j < ntiles; ++j) {
    const Index w = (ncol - c0 + (ntiles - j) - 1) / (ntiles - j);
    const Index t0 = has_v ? std::max<Index>(c0 - 1, 0) : c0;  // start of the tile's first column
    double* out = packed.data() + used;
    for (Index t = t0; t < r; ++t)
      for (Index c = 0; c < w; ++c) {
        const Index col = c0 + c;
        double value;
        if (has_v && col == 0) {
          value = v[t];
        } else {
          const Index q = has_v ? col - 1 : col;
          value = t >= q ? Ld[q * r + t] : 0.0;
        }
        out[(t - t0) * w + c] = value;
      }
    tile_t0.push_back(static_cast<int>(t0));
    tile_width.push_back(static_cast<int>(w));
    tile_coef.push_back(out);
    used += (r - t0) * w;
    c0 += w;
  }
  Index row0 = 0;
  for (; row0 + 8 <= m; row0 += 8)
    PanelKernel<2>(cols.data(), row0, ri, tile_t0, tile_width, tile_coef, has_v, sq + row0, cross + row0,
                   has_v ? gv + row0 : nullptr);
  if (row0 + 4 <= m) {
    PanelKernel<1>(cols.data(), row0, ri, tile_t0, tile_width, tile_coef, has_v, sq + row0, cross + row0,
                   has_v ? gv + row0 : nullptr);
    row0 += 4;
  }
  if (row0 < m) {  // the last subsystem (2 rows), padded to one row vector
    double pad[4 * 64], s4[4], x4[4], g4[4];
    thread_local std::vector<double> big;
    double* buf = pad;
    if (r > 64) {
      big.resize(static_cast<std::size_t>(4 * r));
      buf = big.data();
    }
    thread_local std::vector<const double*> pcols;
    pcols.resize(static_cast<std::size_t>(r));
    for (Index t = 0; t < r; ++t) {
      buf[4 * t] = cols[t][row0];
      buf[4 * t + 1] = cols[t][row0 + 1];
      buf[4 * t + 2] = buf[4 * t + 3] = 0.0;
      pcols[t] = buf + 4 * t;
    }
    PanelKernel<1>(pcols.data(), 0, ri, tile_t0, tile_width, tile_coef, has_v, s4, x4, g4);
    for (Index j = 0; j < 2; ++j) {
      sq[row0 + j] = s4[j];
      cross[row0 + j] = x4[j];
      if (has_v) gv[row0 + j] = g4[j];
    }
  }
}

#else

void Pass2C2Avx2(Index, Index, Index, const double*, Index, const double*, const double*, double*, double*, double*) {
  throw Error("Pass2C2Avx2: called on a CPU without AVX2 (SimdKernelsEnabled() is false)");
}

#endif

}  // namespace kfx::detail
