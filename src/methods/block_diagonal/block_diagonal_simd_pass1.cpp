// AVX2/FMA pass 1 of the block-diagonal filter for c = 2, d = 1 or 2 (src/block_diagonal_simd.hpp).
// Compiled without -mavx2: every function here carries the target attribute and uses only
// intrinsics and plain loops (no Eigen, no inline functions from headers compiled for the baseline).
//
// Design: the subsystems are taken in blocks of up to kBlock = 256 (a multiple of 4; the filter's
// chunk is one block). For a block, Z (block x r) is formed column by column into scratch, four
// subsystems per vector (two G loads, two in-lane unpacks, a multiply and an FMA against the even
// and odd entries of b, which are split once per block), Y^T nu accumulated on the way. Within each
// group of four, Z holds the subsystems in the lane order (l, l + 2, l + 1, l + 3), which Z^T Z does
// not see (rnu is permuted to match). The lower triangle of Z^T Z is a dot-product SYRK vectorized
// over subsystems: a register tile of up to 4 rows x 3 columns of N (12 accumulators, 7 loads per
// 12 FMAs), reduced horizontally into N once per tile and block. The last nb mod 4 subsystems go
// through scalar loops.
#include "methods/block_diagonal/block_diagonal_simd.hpp"

#include <cstdint>

#include "kfx/error.hpp"

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>

#define KFX_AVX2 __attribute__((target("avx2,fma")))
#define KFX_AVX2_INLINE __attribute__((target("avx2,fma"), always_inline)) inline

namespace kfx::detail {

namespace {

using Eigen::Index;

constexpr Index kBlock = 256;  // subsystems per block (the filter's chunk): b and rnu of a block on the stack

// Sum of the four lanes.
KFX_AVX2_INLINE double HorizontalSum(__m256d v) {
  const __m128d s = _mm_add_pd(_mm256_castpd256_pd128(v), _mm256_extractf128_pd(v, 1));
  return _mm_cvtsd_f64(_mm_add_sd(s, _mm_unpackhi_pd(s, s)));
}

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
KFX_AVX2 void SyrkColumnBlock(Index m, const double* z, Index r, Index j0, double* N) {
  Index i0 = j0;
  for (; i0 + 4 <= r; i0 += 4) SyrkTile<4, NR>(m, z, i0, j0, N, r);
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

// Z (m x r, leading dimension m) of the m subsystems at b, g (m <= kBlock, a multiple of 4), in
// the lane order (l, l + 2, l + 1, l + 3) within each group of four (Z^T Z does not depend on the
// order of the subsystems); ytnu += Z^T rnu with rnu in the same order.
KFX_AVX2 void FormZ(Index m, Index r, const double* b, const double* g, Index ldg, const double* rnu, double* z,
                    double* ytnu) {
  // The even and odd entries of b (first and second state of each subsystem) and rnu, in lane order.
  alignas(32) double be[kBlock], bo[kBlock], rp[kBlock];
  for (Index l = 0; l < m; l += 4) {
    const __m256d b0 = _mm256_loadu_pd(b + 2 * l), b1 = _mm256_loadu_pd(b + 2 * l + 4);
    _mm256_store_pd(be + l, _mm256_unpacklo_pd(b0, b1));
    _mm256_store_pd(bo + l, _mm256_unpackhi_pd(b0, b1));
    if (rnu) _mm256_store_pd(rp + l, _mm256_permute4x64_pd(_mm256_loadu_pd(rnu + l), 0xD8));
  }
  for (Index t = 0; t < r; ++t) {
    const double* gt = g + t * ldg;
    const char* next = reinterpret_cast<const char*>(t + 1 < r ? gt + ldg : gt);  // prefetched along
    double* zt = z + t * m;
    if (rnu) {
      __m256d acc = _mm256_setzero_pd();
      for (Index l = 0; l < m; l += 4) {
        _mm_prefetch(next + 16 * l, _MM_HINT_T0);
        const __m256d g0 = _mm256_loadu_pd(gt + 2 * l), g1 = _mm256_loadu_pd(gt + 2 * l + 4);
        const __m256d zl = _mm256_fmadd_pd(_mm256_unpackhi_pd(g0, g1), _mm256_load_pd(bo + l),
                                           _mm256_mul_pd(_mm256_unpacklo_pd(g0, g1), _mm256_load_pd(be + l)));
        _mm256_store_pd(zt + l, zl);
        acc = _mm256_fmadd_pd(_mm256_load_pd(rp + l), zl, acc);
      }
      ytnu[t] += HorizontalSum(acc);
    } else {
      for (Index l = 0; l < m; l += 4) {
        _mm_prefetch(next + 16 * l, _MM_HINT_T0);
        const __m256d g0 = _mm256_loadu_pd(gt + 2 * l), g1 = _mm256_loadu_pd(gt + 2 * l + 4);
        _mm256_store_pd(zt + l, _mm256_fmadd_pd(_mm256_unpackhi_pd(g0, g1), _mm256_load_pd(bo + l),
                                                _mm256_mul_pd(_mm256_unpacklo_pd(g0, g1), _mm256_load_pd(be + l))));
      }
    }
  }
}

// Z (m x r, leading dimension m, m a multiple of 4) of the m / 2 subsystems at B, g for d = 2: Z
// row 2 l + p = B_l(p, :) G_l, in G's row order. With x = (g_{2l}, g_{2l+1}, g_{2l+2}, g_{2l+3}) a
// vector of G's column t, z = (B_l(0,0), B_l(1,1), ...) x + (B_l(0,1), B_l(1,0), ...) swap(x);
// ytnu += Z^T rnu (rnu in the same row order).
KFX_AVX2 void FormZD2(Index m, Index r, const double* B, const double* g, Index ldg, const double* rnu, double* z,
                      double* ytnu) {
  alignas(32) double bd[kBlock], bo[kBlock];
  for (Index q = 0; q < m; q += 2) {
    const double* bl = B + 2 * q;  // column-major B_l of subsystem q / 2: B00, B10, B01, B11
    bd[q] = bl[0];
    bd[q + 1] = bl[3];
    bo[q] = bl[2];
    bo[q + 1] = bl[1];
  }
  for (Index t = 0; t < r; ++t) {
    const double* gt = g + t * ldg;
    const char* next = reinterpret_cast<const char*>(t + 1 < r ? gt + ldg : gt);  // prefetched along
    double* zt = z + t * m;
    __m256d acc = _mm256_setzero_pd();
    for (Index q = 0; q < m; q += 4) {
      _mm_prefetch(next + 8 * q, _MM_HINT_T0);
      const __m256d x = _mm256_loadu_pd(gt + q);
      const __m256d zq =
          _mm256_fmadd_pd(_mm256_permute_pd(x, 0x5), _mm256_load_pd(bo + q), _mm256_mul_pd(x, _mm256_load_pd(bd + q)));
      _mm256_store_pd(zt + q, zq);
      if (rnu) acc = _mm256_fmadd_pd(_mm256_loadu_pd(rnu + q), zq, acc);
    }
    if (rnu) ytnu[t] += HorizontalSum(acc);
  }
}

// The lower triangle of Z^T Z (m a multiple of 4) added to N (r x r).
KFX_AVX2 void SyrkLower(Index m, const double* z, Index r, double* N) {
  Index j0 = 0;
  for (; j0 + 3 <= r; j0 += 3) SyrkColumnBlock<3>(m, z, r, j0, N);
  if (r - j0 == 2) SyrkColumnBlock<2>(m, z, r, j0, N);
  if (r - j0 == 1) SyrkColumnBlock<1>(m, z, r, j0, N);
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
    SyrkLower(mb, z, r, N);
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

KFX_AVX2 void Pass1C2D2Avx2(Index nb, Index r, const double* B, const double* g, Index ldg, const double* rnu,
                            double* N, double* ytnu, double* scratch) {
  if (nb <= 0 || r <= 0) return;
  const Index m = 2 * (nb & ~Index{1});  // Z rows done four per vector (two subsystems)
  const Index blk = m < kBlock ? m : kBlock;
  double* z = reinterpret_cast<double*>((reinterpret_cast<std::uintptr_t>(scratch) + 31) & ~std::uintptr_t{31});
  for (Index q0 = 0; q0 < m; q0 += blk) {
    const Index mb = m - q0 < blk ? m - q0 : blk;
    FormZD2(mb, r, B + 2 * q0, g + q0, ldg, rnu ? rnu + q0 : nullptr, z, ytnu);
    SyrkLower(mb, z, r, N);
  }
  if (m == 2 * nb) return;
  // The last subsystem (odd nb): its two Z rows one at a time (r doubles after the Z block;
  // blk r + r <= 2 nb r).
  double* zrow = z + blk * r;
  const Index l = nb - 1;
  const double* bl = B + 4 * l;
  for (Index p = 0; p < 2; ++p) {
    for (Index t = 0; t < r; ++t) zrow[t] = bl[p] * g[t * ldg + 2 * l] + bl[2 + p] * g[t * ldg + 2 * l + 1];
    for (Index j = 0; j < r; ++j) {
      for (Index i = j; i < r; ++i) N[j * r + i] += zrow[i] * zrow[j];
    }
    if (rnu) {
      for (Index t = 0; t < r; ++t) ytnu[t] += rnu[2 * l + p] * zrow[t];
    }
  }
}

}  // namespace kfx::detail

#else

namespace kfx::detail {
void Pass1C2D1Avx2(Eigen::Index, Eigen::Index, const double*, const double*, Eigen::Index, const double*, double*,
                   double*, double*) {
  throw Error("Pass1C2D1Avx2: called on a CPU without AVX2 (SimdKernelsEnabled() is false)");
}
void Pass1C2D2Avx2(Eigen::Index, Eigen::Index, const double*, const double*, Eigen::Index, const double*, double*,
                   double*, double*) {
  throw Error("Pass1C2D2Avx2: called on a CPU without AVX2 (SimdKernelsEnabled() is false)");
}
}  // namespace kfx::detail

#endif
