// AVX2/FMA kernels of the block-diagonal passes (src/methods/block_diagonal/block_diagonal_simd.hpp) against
// straightforward loops on seeded random data: every tail of nb and r, strided G, null and
// non-null rnu, accumulation into non-zero N and ytnu, the strict upper triangle of N untouched,
// nothing read beyond the stated extents (NaN there) or written beyond the scratch size.
#include "methods/block_diagonal/block_diagonal_simd.hpp"
#include "methods/block_diagonal/block_diagonal_internal.hpp"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

namespace kfx {
namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

bool HasAvx2Fma() { return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma"); }

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kSentinel = 777.25;

// One Pass1C2D1Avx2 (d = 1) or Pass1C2D2Avx2 (d = 2) call against triple loops (failures reported
// through gtest expectations). b holds each subsystem's d x 2 whitened measurement matrix, column-major.
void CheckPass1(Index d, Index nb, Index r, Index extra_rows, bool with_rnu, std::uint64_t seed) {
  SCOPED_TRACE(::testing::Message() << "d = " << d << ", nb = " << nb << ", r = " << r << ", ldg = 2 nb + "
                                    << extra_rows << (with_rnu ? ", rnu" : ", rnu null"));
  std::mt19937_64 gen(seed);
  std::normal_distribution<double> normal;
  const Index ldg = 2 * nb + extra_rows;
  // G rows beyond 2 nb, b beyond 2 d nb and rnu beyond d nb are NaN: reading them would show in N.
  MatrixXd G(std::max<Index>(ldg, 1), r);
  for (Index t = 0; t < r; ++t) {
    for (Index i = 0; i < ldg; ++i) G(i, t) = i < 2 * nb ? normal(gen) : kNaN;
  }
  VectorXd b = VectorXd::Constant(2 * d * nb + 8, kNaN), rnu = VectorXd::Constant(d * nb + 8, kNaN);
  for (Index i = 0; i < 2 * d * nb; ++i) b[i] = normal(gen);
  for (Index i = 0; i < d * nb; ++i) rnu[i] = normal(gen);
  // N starts non-zero (lower triangle), the strict upper triangle holds a sentinel.
  MatrixXd N0(r, r);
  for (Index j = 0; j < r; ++j) {
    for (Index i = 0; i < r; ++i) N0(i, j) = i >= j ? normal(gen) : kSentinel;
  }
  VectorXd y0(r);
  for (Index t = 0; t < r; ++t) y0[t] = normal(gen);

  // Reference: z_{l,p} = b_l(p, :) G_l, N += sum z^T z, ytnu += sum rnu_{l,p} z_{l,p}; scale = the
  // same sums of absolute values (the magnitude the rounding errors are relative to).
  MatrixXd N_ref = N0, N_scale = N0.cwiseAbs();
  VectorXd y_ref = y0, y_scale = y0.cwiseAbs();
  VectorXd z(r), za(r);
  for (Index l = 0; l < nb; ++l) {
    for (Index p = 0; p < d; ++p) {
      const double b0 = b[2 * d * l + p], b1 = b[2 * d * l + d + p];
      for (Index t = 0; t < r; ++t) {
        z[t] = b0 * G(2 * l, t) + b1 * G(2 * l + 1, t);
        za[t] = std::abs(b0 * G(2 * l, t)) + std::abs(b1 * G(2 * l + 1, t));
      }
      for (Index j = 0; j < r; ++j) {
        for (Index i = j; i < r; ++i) {
          N_ref(i, j) += z[i] * z[j];
          N_scale(i, j) += za[i] * za[j];
        }
      }
      if (with_rnu) {
        for (Index t = 0; t < r; ++t) {
          y_ref[t] += rnu[d * l + p] * z[t];
          y_scale[t] += std::abs(rnu[d * l + p]) * za[t];
        }
      }
    }
  }

  // Scratch of exactly d nb r + 64 doubles, deliberately not 32-byte aligned, followed by a guard.
  const Index scratch_size = d * nb * r + 64, guard = 16;
  std::vector<double> scratch_buffer(static_cast<size_t>(scratch_size + guard + 1), 0.0);
  double* scratch = scratch_buffer.data() + 1;
  for (Index i = scratch_size; i < scratch_size + guard; ++i) scratch[i] = kSentinel;

  MatrixXd N = N0;
  VectorXd y = y0;
  const double* rnu_arg = with_rnu ? rnu.data() : nullptr;
  if (d == 1) {
    detail::Pass1C2D1Avx2(nb, r, b.data(), G.data(), ldg, rnu_arg, N.data(), y.data(), scratch);
  } else {
    detail::Pass1C2D2Avx2(nb, r, b.data(), G.data(), ldg, rnu_arg, N.data(), y.data(), scratch);
  }

  for (Index j = 0; j < r; ++j) {
    for (Index i = 0; i < r; ++i) {
      if (i < j) {
        EXPECT_EQ(N(i, j), kSentinel) << "upper triangle written at (" << i << ", " << j << ")";
      } else {
        EXPECT_LE(std::abs(N(i, j) - N_ref(i, j)), 1e-13 * N_scale(i, j))
            << "N(" << i << ", " << j << ") = " << N(i, j) << ", reference " << N_ref(i, j);
      }
    }
  }
  for (Index t = 0; t < r; ++t) {
    if (with_rnu) {
      EXPECT_LE(std::abs(y[t] - y_ref[t]), 1e-13 * y_scale[t])
          << "ytnu[" << t << "] = " << y[t] << ", reference " << y_ref[t];
    } else {
      EXPECT_EQ(y[t], y0[t]) << "ytnu changed with rnu null";
    }
  }
  for (Index i = scratch_size; i < scratch_size + guard; ++i) {
    EXPECT_EQ(scratch[i], kSentinel) << "scratch written beyond d nb r + 64 at " << i;
  }
}

TEST(BlockDiagonalSimdTest, Pass1MatchesLoopsForEveryTail) {
  if (!HasAvx2Fma()) GTEST_SKIP() << "CPU without AVX2/FMA";
  std::uint64_t seed = 1;
  for (Index nb : {0, 1, 3, 4, 5, 7, 8, 63, 64, 65, 255, 256}) {
    for (Index r : {0, 1, 2, 3, 4, 5, 19, 20, 21, 33}) {
      CheckPass1(1, nb, r, 0, true, seed++);
      CheckPass1(1, nb, r, 6, false, seed++);
      CheckPass1(1, nb, r, 13, true, seed++);
      if (::testing::Test::HasFailure()) return;  // one report per broken shape is enough
    }
  }
}

TEST(BlockDiagonalSimdTest, Pass1LargeChunkAndWideCoupling) {
  if (!HasAvx2Fma()) GTEST_SKIP() << "CPU without AVX2/FMA";
  CheckPass1(1, 1001, 20, 40, true, 101);  // beyond the filter's chunk of 256
  CheckPass1(1, 256, 64, 2, true, 102);
  CheckPass1(1, 9, 70, 1, true, 103);
}

TEST(BlockDiagonalSimdTest, Pass1TwoMeasurementsMatchesLoopsForEveryTail) {
  if (!HasAvx2Fma()) GTEST_SKIP() << "CPU without AVX2/FMA";
  std::uint64_t seed = 300;
  for (Index nb : {0, 1, 2, 3, 4, 5, 127, 128, 129, 256}) {
    for (Index r : {0, 1, 2, 3, 4, 5, 19, 20, 21}) {
      CheckPass1(2, nb, r, 0, true, seed++);
      CheckPass1(2, nb, r, 5, false, seed++);
      if (::testing::Test::HasFailure()) return;
    }
  }
  CheckPass1(2, 301, 20, 3, true, 399);  // several 128-subsystem blocks and an odd tail
}

// One Pass2C2Avx2 call against loops: w_j = g(j, :) Ld, sq_j = |w_j|^2, cross_j = w_j . w_{j xor 1},
// gv_j = g(j, :) v. Ld's strict upper triangle and G's rows beyond 2 nb are NaN (must not be read);
// the outputs beyond 2 nb hold a sentinel (must not be written).
void CheckPass2(Index nb, Index r, Index k, Index extra_rows, bool with_v, std::uint64_t seed) {
  SCOPED_TRACE(::testing::Message() << "nb = " << nb << ", r = " << r << ", k = " << k << ", ldg = 2 nb + "
                                    << extra_rows << (with_v ? ", v" : ", v null"));
  std::mt19937_64 gen(seed);
  std::normal_distribution<double> normal;
  const Index ldg = 2 * nb + extra_rows, m = 2 * nb;
  MatrixXd G(std::max<Index>(ldg, 1), r);
  for (Index t = 0; t < r; ++t) {
    for (Index i = 0; i < ldg; ++i) G(i, t) = i < m ? normal(gen) : kNaN;
  }
  MatrixXd Ld(r, k);
  for (Index q = 0; q < k; ++q) {
    for (Index t = 0; t < r; ++t) Ld(t, q) = t >= q ? normal(gen) : kNaN;
  }
  VectorXd v(r);
  for (Index t = 0; t < r; ++t) v[t] = normal(gen);
  const Index pad = 5;
  VectorXd sq = VectorXd::Constant(m + pad, kSentinel), cross = sq, gv = sq;
  detail::Pass2C2Avx2(nb, r, k, G.data(), ldg, Ld.data(), with_v ? v.data() : nullptr, sq.data(), cross.data(),
                      gv.data());
  MatrixXd W = MatrixXd::Zero(m, k), Wa = MatrixXd::Zero(m, k);  // W and the sums of |terms|
  for (Index j = 0; j < m; ++j) {
    for (Index q = 0; q < k; ++q) {
      for (Index t = q; t < r; ++t) {
        W(j, q) += G(j, t) * Ld(t, q);
        Wa(j, q) += std::abs(G(j, t) * Ld(t, q));
      }
    }
  }
  for (Index j = 0; j < m; ++j) {
    const Index p = j ^ 1;
    // Sums over q by hand: with k = 0, W is m x 0 and W.row(j) would offset its null data pointer (UB).
    double sq_ref = 0.0, cross_ref = 0.0, scale_sq = 0.0, scale_cross = 0.0;
    for (Index q = 0; q < k; ++q) {
      sq_ref += W(j, q) * W(j, q);
      cross_ref += W(j, q) * W(p, q);
      scale_sq += Wa(j, q) * Wa(j, q);
      scale_cross += Wa(j, q) * Wa(p, q);
    }
    EXPECT_LE(std::abs(sq[j] - sq_ref), 1e-13 * scale_sq) << "sq[" << j << "]";
    EXPECT_LE(std::abs(cross[j] - cross_ref), 1e-13 * scale_cross) << "cross[" << j << "]";
    if (with_v) {
      double gv_ref = 0.0, gv_scale = 0.0;
      for (Index t = 0; t < r; ++t) {
        gv_ref += G(j, t) * v[t];
        gv_scale += std::abs(G(j, t) * v[t]);
      }
      EXPECT_LE(std::abs(gv[j] - gv_ref), 1e-13 * gv_scale) << "gv[" << j << "]";
    }
  }
  for (Index j = m; j < m + pad; ++j) {
    EXPECT_EQ(sq[j], kSentinel);
    EXPECT_EQ(cross[j], kSentinel);
    EXPECT_EQ(gv[j], kSentinel);
  }
  if (!with_v) {
    for (Index j = 0; j < m; ++j) EXPECT_EQ(gv[j], kSentinel) << "gv written with v null";
  }
}

TEST(BlockDiagonalSimdTest, Pass2MatchesLoopsForEveryTail) {
  if (!HasAvx2Fma()) GTEST_SKIP() << "CPU without AVX2/FMA";
  std::uint64_t seed = 7;
  for (Index nb : {0, 1, 2, 3, 4, 5, 7, 8, 9, 255, 256}) {
    for (Index r : {1, 2, 5, 6, 7, 12, 19, 20, 21}) {
      for (Index k : {r, (r + 1) / 2, Index{0}}) {
        CheckPass2(nb, r, k, 0, true, seed++);
        CheckPass2(nb, r, k, 7, false, seed++);
        if (::testing::Test::HasFailure()) return;
      }
    }
  }
  CheckPass2(3, 70, 70, 2, true, 99);  // wide coupling: the padded last subsystem's heap buffer
  CheckPass2(1000, 20, 20, 1, true, 98);
}

// C_1 = (U^{-1} + N)^{-1} and its lower trapezoidal factor, for U positive definite, singular
// (rank 2 of 5: the QR branch) and zero, against the closed form where U is invertible.
TEST(BlockDiagonalFactor, LowerTrapezoidalFactorOfTheCouplingCovariance) {
  std::mt19937_64 gen(5);
  std::normal_distribution<double> normal;
  auto gaussian = [&](Index rows, Index cols) {
    MatrixXd m(rows, cols);
    for (Index j = 0; j < cols; ++j) {
      for (Index i = 0; i < rows; ++i) m(i, j) = normal(gen);
    }
    return m;
  };
  const Index r = 5;
  const MatrixXd Z = gaussian(9, r), N = Z.transpose() * Z;
  for (const Index rank : {Index{5}, Index{2}, Index{0}}) {
    SCOPED_TRACE("rank of U " + std::to_string(rank));
    const MatrixXd B = gaussian(r, rank),
                   U = B * B.transpose() + (rank == r ? MatrixXd::Identity(r, r) : MatrixXd(MatrixXd::Zero(r, r)));
    MatrixXd C1;
    const detail::CouplingFactor f = detail::BlockDiagonalFactor(U, N, &C1);
    ASSERT_EQ(f.Ld.rows(), r);
    ASSERT_EQ(f.FcT.cols(), r);
    for (Index q = 0; q < f.Ld.cols(); ++q) {
      for (Index t = 0; t < q; ++t) EXPECT_EQ(f.Ld(t, q), 0.0) << "Ld(" << t << ", " << q << ")";
    }
    EXPECT_LE((f.Ld * f.Ld.transpose() - C1).norm(), 1e-14 * std::max(C1.norm(), 1.0));
    EXPECT_LE((f.FcT - f.Ld.transpose()).norm(), 0.0);
    // Independent: C_1 = U - U (I + N U)^{-1} N U (Woodbury; valid for singular U too).
    const MatrixXd I = MatrixXd::Identity(r, r);
    const MatrixXd C1_ref = U - U * (I + N * U).partialPivLu().solve(N * U);
    EXPECT_LE((C1 - C1_ref).norm(), 1e-12 * std::max(C1_ref.norm(), 1.0));
    if (rank == 0) {
      EXPECT_EQ(C1.norm(), 0.0);
    }
  }
}

}  // namespace
}  // namespace kfx
