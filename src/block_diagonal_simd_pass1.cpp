// AVX2/FMA pass 1 of the block-diagonal filter for c = 2, d = 1 (src/block_diagonal_simd.hpp).
// Compiled without -mavx2: every function here carries the target attribute and uses only
// intrinsics and plain loops (no Eigen, no inline functions from headers compiled for the baseline).
//
// Design: the subsystems are taken in blocks of up to kBlock (a multiple of 4). For a block, Z
// (block x r) is formed column by column into scratch, four subsystems per vector (two G loads, two
// products against b, one horizontal add, one lane permutation), Y^T nu accumulated on the way. The
// lower triangle of Z^T Z is then a dot-product SYRK vectorized over subsystems: a register tile of
// up to 4 rows x 3 columns of N (12 accumulators, 7 loads per 12 FMAs), reduced horizontally into N
// once per tile and block. Between tiles, the G columns of the next block are prefetched, so that
// streaming G (memory or L3) overlaps the FMAs. The last nb mod 4 subsystems go through scalar loops.
#include <immintrin.h>

#include <cstdint>

#include "block_diagonal_simd.hpp"

#define KFX_AVX2 __attribute__((target("avx2,fma")))
#define KFX_AVX2_INLINE __attribute__((target("avx2,fma"), always_inline)) inline

namespace kfx::detail {

namespace {

using Eigen::Index;

#ifndef KFX_P1_BLOCK
#define KFX_P1_BLOCK 64
#endif
constexpr Index kBlock = KFX_P1_BLOCK;  // subsystems per block: Z block of kBlock r doubles stays in L1

// Sum of the four lanes.
KFX_AVX2_INLINE double HorizontalSum(__m256d v) {
  const __m128d s = _mm_add_pd(_mm256_castpd256_pd128(v), _mm256_extractf128_pd(v, 1));
  return _mm_cvtsd_f64(_mm_add_sd(s, _mm_unpackhi_pd(s, s)));
}

// Prefetches the G rows of the next block, one column per call.
struct GPrefetch {
  const double* g;    // first row of the next block in column 0
  Index ldg, r, len;  // len: doubles per column (2 subsystems' rows each), 0 when no next block
  Index t;
  KFX_AVX2_INLINE void Column() {
    if (t >= r || len == 0) return;
    const double* gt = g + t * ldg;
    for (Index k = 0; k < len; k += 8) _mm_prefetch(reinterpret_cast<const char*>(gt + k), _MM_HINT_T0);
    _mm_prefetch(reinterpret_cast<const char*>(gt + len - 1), _MM_HINT_T0);
    ++t;
  }
};

// N(i0 + a, j0 + q) += sum_{l < m} Z(l, i0 + a) Z(l, j0 + q) for a < MR, q < NR and
// i0 + a >= j0 + q (Z column-major, leading dimension m, m a multiple of 4, 32-byte aligned).
template <int MR, int NR>
KFX_AVX2 void SyrkTile(Index m, const double* z, Index i0, Index j0, double* N, Index ldn) {
  __m256d acc[MR][NR];
#pragma GCC unroll 4
  for (int a = 0; a < MR; ++a) {
#pragma GCC unroll 4
    for (int q = 0; q < NR; ++q) acc[a][q] = _mm256_setzero_pd();
  }
  const double* zi = z + i0 * m;
  const double* zj = z + j0 * m;
  for (Index l = 0; l < m; l += 4) {
    __m256d cj[NR];
#pragma GCC unroll 4
    for (int q = 0; q < NR; ++q) cj[q] = _mm256_load_pd(zj + q * m + l);
#pragma GCC unroll 4
    for (int a = 0; a < MR; ++a) {
      const __m256d ri = _mm256_load_pd(zi + a * m + l);
#pragma GCC unroll 4
      for (int q = 0; q < NR; ++q) acc[a][q] = _mm256_fmadd_pd(ri, cj[q], acc[a][q]);
    }
  }
  if constexpr (MR == 4) {
    // Four rows at once: (sum acc[0], ..., sum acc[3]) by two horizontal adds and a lane swap.
#pragma GCC unroll 4
    for (int q = 0; q < NR; ++q) {
      const __m256d h01 = _mm256_hadd_pd(acc[0][q], acc[1][q]);
      const __m256d h23 = _mm256_hadd_pd(acc[2][q], acc[3][q]);
      const __m256d s = _mm256_add_pd(_mm256_permute2f128_pd(h01, h23, 0x20), _mm256_permute2f128_pd(h01, h23, 0x31));
      double* nq = N + (j0 + q) * ldn + i0;
      if (i0 >= j0 + q) {
        _mm256_storeu_pd(nq, _mm256_add_pd(_mm256_loadu_pd(nq), s));
      } else {  // diagonal tile: only rows i0 + a >= j0 + q
        alignas(32) double t[4];
        _mm256_store_pd(t, s);
        for (int a = 0; a < 4; ++a) {
          if (i0 + a >= j0 + q) nq[a] += t[a];
        }
      }
    }
  } else {
#pragma GCC unroll 4
    for (int a = 0; a < MR; ++a) {
#pragma GCC unroll 4
      for (int q = 0; q < NR; ++q) {
        if (i0 + a >= j0 + q) N[(j0 + q) * ldn + i0 + a] += HorizontalSum(acc[a][q]);
      }
    }
  }
}

// Columns j0 .. j0 + NR - 1 of the lower triangle, rows j0 .. r - 1.
template <int NR>
KFX_AVX2 void SyrkColumnBlock(Index m, const double* z, Index r, Index j0, double* N, GPrefetch* pf) {
  Index i0 = j0;
  for (; i0 + 4 <= r; i0 += 4) {
    pf->Column();
    SyrkTile<4, NR>(m, z, i0, j0, N, r);
  }
  switch (r - i0) {
    case 3:
      SyrkTile<3, NR>(m, z, i0, j0, N, r);
      break;
    case 2:
      SyrkTile<2, NR>(m, z, i0, j0, N, r);
      break;
    case 1:
      SyrkTile<1, NR>(m, z, i0, j0, N, r);
      break;
    default:
      break;
  }
}

// Z (m x r, leading dimension m) of the m subsystems at b, g (m a multiple of 4); ytnu += Z^T rnu.
KFX_AVX2 void FormZ(Index m, Index r, const double* b, const double* g, Index ldg, const double* rnu, double* z,
                    double* ytnu) {
  for (Index t = 0; t < r; ++t) {
    const double* gt = g + t * ldg;
    double* zt = z + t * m;
    __m256d acc = _mm256_setzero_pd();
    for (Index l = 0; l < m; l += 4) {
      const __m256d p0 = _mm256_mul_pd(_mm256_loadu_pd(gt + 2 * l), _mm256_loadu_pd(b + 2 * l));
      const __m256d p1 = _mm256_mul_pd(_mm256_loadu_pd(gt + 2 * l + 4), _mm256_loadu_pd(b + 2 * l + 4));
      // hadd gives (z_l, z_{l+2}, z_{l+1}, z_{l+3}); put the lanes in subsystem order.
      const __m256d zl = _mm256_permute4x64_pd(_mm256_hadd_pd(p0, p1), 0xD8);
      _mm256_store_pd(zt + l, zl);
      if (rnu) acc = _mm256_fmadd_pd(_mm256_loadu_pd(rnu + l), zl, acc);
    }
    if (rnu) ytnu[t] += HorizontalSum(acc);
  }
}

}  // namespace

KFX_AVX2 void Pass1C2D1Avx2(Index nb, Index r, const double* b, const double* g, Index ldg, const double* rnu,
                            double* N, double* ytnu, double* scratch) {
  if (nb <= 0 || r <= 0) return;
  const Index m = nb & ~Index{3};  // subsystems done four per vector
  const Index blk = m < kBlock ? m : kBlock;
  // Z of one block (blk x r, column-major) in scratch, aligned to 32 bytes (at most 3 doubles lost).
  double* z = reinterpret_cast<double*>((reinterpret_cast<std::uintptr_t>(scratch) + 31) & ~std::uintptr_t{31});
  for (Index l0 = 0; l0 < m; l0 += blk) {
    const Index mb = m - l0 < blk ? m - l0 : blk;
    FormZ(mb, r, b + 2 * l0, g + 2 * l0, ldg, rnu ? rnu + l0 : nullptr, z, ytnu);
    const Index next = l0 + mb;
    GPrefetch pf{g + 2 * next, ldg, r, 2 * (m - next < blk ? m - next : blk), 0};
    Index j0 = 0;
    for (; j0 + 3 <= r; j0 += 3) SyrkColumnBlock<3>(mb, z, r, j0, N, &pf);
    if (r - j0 == 2) SyrkColumnBlock<2>(mb, z, r, j0, N, &pf);
    if (r - j0 == 1) SyrkColumnBlock<1>(mb, z, r, j0, N, &pf);
    while (pf.t < r && pf.len > 0) pf.Column();
  }
  // The last nb mod 4 subsystems: one z row at a time (r doubles of scratch after the Z block;
  // blk r + r <= nb r since blk <= m < nb here).
  double* zrow = z + blk * r;
  for (Index l = m; l < nb; ++l) {
    for (Index t = 0; t < r; ++t) zrow[t] = b[2 * l] * g[t * ldg + 2 * l] + b[2 * l + 1] * g[t * ldg + 2 * l + 1];
    for (Index j = 0; j < r; ++j) {
      for (Index i = j; i < r; ++i) N[j * r + i] += zrow[i] * zrow[j];
    }
    if (rnu) {
      for (Index t = 0; t < r; ++t) ytnu[t] += rnu[l] * zrow[t];
    }
  }
}

}  // namespace kfx::detail
