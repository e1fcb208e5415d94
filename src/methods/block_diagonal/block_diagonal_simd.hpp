#pragma once
// AVX2/FMA kernels of the O(n r^2) block-diagonal passes (004 eqs. (8)-(17)) for the paper's shape
// c = 2 (two states per subsystem), chosen at run time when the CPU has AVX2 and FMA. The portable
// kernels in block_diagonal_passes.cpp stay the reference (tests compare the two) and the fallback.
// Compiled with per-function target attributes (no -mavx2 for the file): nothing here may be
// inlined into, or call, code compiled for the baseline ISA except through these entry points.
#include <Eigen/Core>

namespace kfx::detail {

/// True when the CPU has AVX2 and FMA (checked once) and SetBlockDiagonalSpecializedKernels has not
/// disabled the specialized kernels.
bool SimdKernelsEnabled();

/// Pass 1 for c = 2, d = 1 over nb subsystems: z_l = b_l G_l (1 x r), with b_l = (b[2 l], b[2 l + 1])
/// the whitened measurement row R_c^{-T} H_l and G_l rows 2 l, 2 l + 1 of the column-major g (r
/// columns, leading dimension ldg). Adds sum_l z_l^T z_l to the lower triangle (row >= column) of N
/// (r x r, column-major, leading dimension r; the strict upper triangle is not read or written) and,
/// when rnu is not null, sum_l rnu[l] z_l to ytnu (length r). scratch holds at least nb * r + 64
/// doubles. nb, r >= 0 arbitrary (tails handled inside).
void Pass1C2D1Avx2(Eigen::Index nb, Eigen::Index r, const double* b, const double* g, Eigen::Index ldg,
                   const double* rnu, double* N, double* ytnu, double* scratch);

/// Pass 1 for c = 2, d = 2 over nb subsystems: Z_l = B_l G_l (2 x r), with B_l the whitened
/// measurement matrix R_c^{-T} H_l (2 x 2, column-major at B + 4 l) and G_l rows 2 l, 2 l + 1 of g
/// (as above). Adds sum_l Z_l^T Z_l to the lower triangle of N and, when rnu (length 2 nb, entry
/// 2 l + p for row p of subsystem l) is not null, sum_l Z_l^T rnu_l to ytnu. scratch holds at least
/// 2 nb r + 64 doubles.
void Pass1C2D2Avx2(Eigen::Index nb, Eigen::Index r, const double* B, const double* g, Eigen::Index ldg,
                   const double* rnu, double* N, double* ytnu, double* scratch);

/// Pass 2 for c = 2 over the 2 nb rows of g (column-major, r columns, leading dimension ldg): with
/// w_j = g(j, :) Ld (1 x k; Ld is r x k column-major, lower trapezoidal: Ld(t, q) is 0 and never read
/// for t < q), writes sq[j] = w_j w_j^T and cross[j] = w_j w_{j xor 1}^T (the other row of the same
/// subsystem), and, when v is not null, gv[j] = g(j, :) v.
void Pass2C2Avx2(Eigen::Index nb, Eigen::Index r, Eigen::Index k, const double* g, Eigen::Index ldg, const double* Ld,
                 const double* v, double* sq, double* cross, double* gv);

}  // namespace kfx::detail
