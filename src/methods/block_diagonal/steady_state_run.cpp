// The block-diagonal filter at its fixed point (004 eq. (19)) on data: the gain K = blockdiag(J) - E C_1 Y^T
// frozen, L steps at a time (RunCoupledFilter's steady state, CoupledFilterOptions::steady_state_tolerance).
//
// With the gain fixed, x_k = F x_{k-1} + K nu_k splits into a local part a and a coupled part b, x = a + b:
//   a_j = F a_{j-1} + J (y_j - H F a_{j-1})                  (a_0 = x_{k0}: each subsystem on its own)
//   b_j = Fc b_{j-1} - E w_j,  Fc = (I - J H) F             (b_0 = 0)
//   w_j = C_1 Y^T nu_j = C_1 (s_j + sum_{l<j} M_{j-1-l} w_l),  s_j = Y^T (y_j - H F a_{j-1}),
//   M_m = sum_i Y_i^T H_i F_i Fc_i^m E_i   (r x r, computed once at the freeze).
// So a group of L steps is one sweep over the subsystems for a and s_1..s_L (reading Y^T once), the
// r-dimensional recursion for w_1..w_L (= mu_u), and one sweep adding b (reading E^T once): E and Y
// stream once per L steps where the running filter streams G twice per step. Exact algebra: the
// estimates are the running filter's with the frozen gain, to rounding.
#include <algorithm>
#include <type_traits>
#include <utility>
#include <vector>

#include "kfx/block_diagonal.hpp"
#include "kfx/error.hpp"
#include "methods/block_diagonal/block_diagonal_shared.hpp"

namespace kfx::detail {

using Eigen::Index;
using Eigen::MatrixXd;

namespace {

// Subsystems per chunk: a chunk's L innovations (nb d x L), its coupled parts (nb c x L) and its blocks of
// E^T, Y^T (r x nb (c + d)) stay in cache between the per-subsystem loops and the GEMMs.
constexpr Index kChunk = 512;

// Sweep 1 for subsystems [0, nb) of a chunk: a_j = F a_{j-1} + J (y_j - H F a_{j-1}), j = 1..L, with a_0
// read from x0 and a_j written to xj[j - 1] (rows of x_filt, chunk-relative), and the innovations
// nu_a,j into column j - 1 of NU (nb d x L, column-major). C, D > 0 fix the shape at compile time.
template <int C, int D>
void LocalSweep(Index c_rt, Index d_rt, Index nb, int L, const double* F, const double* H, const double* J,
                const double* x0, double* const* xj, const double* const* yj, double* NU) {
  const Index c = C > 0 ? C : c_rt, d = D > 0 ? D : d_rt;
  // a, F a and nu: on the stack for a fixed shape, on the heap for the generic one.
  double a_s[C > 0 ? C : 1], fa_s[C > 0 ? C : 1], nu_s[D > 0 ? D : 1];
  const bool fixed = C > 0 && D > 0;
  std::vector<double> heap(fixed ? 0 : static_cast<size_t>(2 * c + d));
  double* a = fixed ? a_s : heap.data();
  double* fa = fixed ? fa_s : heap.data() + c;
  double* nu = fixed ? nu_s : heap.data() + 2 * c;
  for (Index i = 0; i < nb; ++i) {
    const double* Fi = F + i * c * c;  // column-major c x c
    const double* Hi = H + i * d * c;
    const double* Ji = J + i * c * d;
    for (Index p = 0; p < c; ++p) a[p] = x0[i * c + p];
    for (int j = 0; j < L; ++j) {
      for (Index p = 0; p < c; ++p) {
        double acc = 0.0;
        for (Index q = 0; q < c; ++q) acc += Fi[q * c + p] * a[q];
        fa[p] = acc;
      }
      double* nuj = NU + j * nb * d + i * d;
      for (Index e = 0; e < d; ++e) {
        double acc = yj[j][i * d + e];
        for (Index q = 0; q < c; ++q) acc -= Hi[q * d + e] * fa[q];
        nu[e] = acc;
        nuj[e] = acc;
      }
      double* out = xj[j] + i * c;
      for (Index p = 0; p < c; ++p) {
        double acc = fa[p];
        for (Index e = 0; e < d; ++e) acc += Ji[e * c + p] * nu[e];
        a[p] = acc;
        out[p] = acc;
      }
    }
  }
}

// Sweep 2 for a chunk: b_j = Fc b_{j-1} + e_j (b_0 = 0) with e_j column j - 1 of EW (nb c x L, column-major,
// e_j = -E w_j), added to xj[j - 1].
template <int C>
void CoupledSweep(Index c_rt, Index nb, int L, const double* Fc, const double* EW, double* const* xj) {
  const Index c = C > 0 ? C : c_rt;
  double b_s[C > 0 ? C : 1], nb_s[C > 0 ? C : 1];
  std::vector<double> heap(C > 0 ? 0 : static_cast<size_t>(2 * c));
  double* b = C > 0 ? b_s : heap.data();
  double* bn = C > 0 ? nb_s : heap.data() + c;
  for (Index i = 0; i < nb; ++i) {
    const double* Fci = Fc + i * c * c;
    for (Index p = 0; p < c; ++p) b[p] = 0.0;
    for (int j = 0; j < L; ++j) {
      const double* e = EW + j * nb * c + i * c;
      double* out = xj[j] + i * c;
      for (Index p = 0; p < c; ++p) {
        double acc = e[p];
        for (Index q = 0; q < c; ++q) acc += Fci[q * c + p] * b[q];
        bn[p] = acc;
      }
      for (Index p = 0; p < c; ++p) {
        b[p] = bn[p];
        out[p] += bn[p];
      }
    }
  }
}

// The fixed-shape instances for the common (c, d), else the generic one.
template <typename Body>
void DispatchShape(Index c, Index d, Body&& body) {
  using One = std::integral_constant<int, 1>;
  using Two = std::integral_constant<int, 2>;
  using Gen = std::integral_constant<int, 0>;
  if (c == 2 && d == 1) return body(Two{}, One{});
  if (c == 1 && d == 1) return body(One{}, One{});
  if (c == 2 && d == 2) return body(Two{}, Two{});
  body(Gen{}, Gen{});
}

}  // namespace

FrozenBlockDiagonal::FrozenBlockDiagonal(const CoupledStep& s, const MatrixXd& P_filt, int group) : group_(group) {
  KFX_ASSERT(group >= 1);
  BlockDiagonalCovarianceStep st;
  BlockDiagonalCovarianceUpdate(s, P_filt, &st);  // the gain of the next step from the converged P
  gain_ = std::move(st.gain);
  const Index n = s.n(), c = s.c(), d = s.d(), r = s.r();
  F_ = s.F;
  H_ = s.H;
  // Fc_i = (I - J_i H_i) F_i and, per chunk, V_i = H_i F_i Fc_i^m (d x c), Z_i = V_i E_i (d x r, from E^T),
  // M_m += Y^T Z over the chunk (one GEMM per chunk and m).
  Fc_.resize(c, n * c);
  M_.assign(static_cast<size_t>(std::max(group - 1, 0)), MatrixXd::Zero(r, r));
  MatrixXd V(d, kChunk * c), Vn(d, c), Z(kChunk * d, r);
  for (Index i0 = 0; i0 < n; i0 += kChunk) {
    const Index nb = std::min(kChunk, n - i0);
    for (Index i = 0; i < nb; ++i) {
      const Index g = i0 + i;
      const auto F = s.F.middleCols(g * c, c);
      V.middleCols(i * c, c).noalias() = s.H.middleCols(g * c, c) * F;
      Fc_.middleCols(g * c, c) = F;
      Fc_.middleCols(g * c, c).noalias() -= gain_.J.middleCols(g * d, d) * V.middleCols(i * c, c);
    }
    if (r == 0) continue;
    for (int m = 0; m + 1 < group; ++m) {
      for (Index i = 0; i < nb; ++i) {  // Z rows [i d, (i + 1) d) = V_i E_i = V_i (E_i^T)^T
        Z.middleRows(i * d, d).noalias() = V.middleCols(i * c, c) * gain_.Et.middleCols((i0 + i) * c, c).transpose();
      }
      M_[static_cast<size_t>(m)].noalias() += gain_.Yt.middleCols(i0 * d, nb * d) * Z.topRows(nb * d);
      if (m + 2 < group) {
        for (Index i = 0; i < nb; ++i) {
          Vn.noalias() = V.middleCols(i * c, c) * Fc_.middleCols((i0 + i) * c, c);
          V.middleCols(i * c, c) = Vn;
        }
      }
    }
  }
}

void FrozenBlockDiagonal::Run(const TimeSeries& y, int k0, int L, TimeSeries* x_filt, TimeSeries* coupling) const {
  KFX_ASSERT(L >= 1 && L <= group_);
  const Index c = F_.rows(), d = H_.rows(), r = gain_.C1.rows(), n = c > 0 ? F_.cols() / c : 0;
  // Per chunk of subsystems: sweep 1 (the local parts a_j into rows k0 + j, their innovations into NU) and
  // S += Y^T NU (r x L, one GEMM).
  MatrixXd S = MatrixXd::Zero(r, L);
  thread_local MatrixXd NU, EW;
  NU.resize(kChunk * d, L);
  EW.resize(kChunk * c, L);
  std::vector<double*> xj(static_cast<size_t>(L));
  std::vector<const double*> yj(static_cast<size_t>(L));
  for (Index i0 = 0; i0 < n; i0 += kChunk) {
    const Index nb = std::min(kChunk, n - i0);
    for (int j = 0; j < L; ++j) {
      xj[j] = x_filt->row(k0 + j + 1).data() + i0 * c;
      yj[j] = y.row(k0 + j).data() + i0 * d;
    }
    const double* x0 = x_filt->row(k0).data() + i0 * c;
    DispatchShape(c, d, [&](auto C, auto D) {
      LocalSweep<decltype(C)::value, decltype(D)::value>(c, d, nb, L, F_.data() + i0 * c * c, H_.data() + i0 * d * c,
                                                         gain_.J.data() + i0 * c * d, x0, xj.data(), yj.data(),
                                                         NU.data());
    });
    const Eigen::Map<const MatrixXd, 0, Eigen::OuterStride<>> nu(NU.data(), nb * d, L, Eigen::OuterStride<>(nb * d));
    S.noalias() += gain_.Yt.middleCols(i0 * d, nb * d) * nu;
  }
  // No coupling: the r-dimensional recursion is empty and sweep 2 would add zeros to every subsystem.
  if (r == 0) return;
  // The r-dimensional recursion: w_j = C_1 (s_j + sum_{l<j} M_{j-1-l} w_l) = mu_u of step k0 + j.
  MatrixXd Wm(r, L);
  for (int j = 1; j <= L; ++j) {
    Eigen::VectorXd v = S.col(j - 1);
    for (int l = 1; l < j; ++l) v.noalias() += M_[static_cast<size_t>(j - 1 - l)] * Wm.col(l - 1);
    Wm.col(j - 1).noalias() = gain_.C1 * v;
    if (coupling) coupling->row(k0 + j - 1) = Wm.col(j - 1).transpose();
  }
  // Sweep 2 per chunk: EW = -E W (nb c x L, one GEMM), then b_j = Fc b_{j-1} + EW_j added to rows k0 + j.
  const MatrixXd minus_w = -Wm;
  for (Index i0 = 0; i0 < n; i0 += kChunk) {
    const Index nb = std::min(kChunk, n - i0);
    Eigen::Map<MatrixXd, 0, Eigen::OuterStride<>> ew(EW.data(), nb * c, L, Eigen::OuterStride<>(nb * c));
    ew.noalias() = gain_.Et.middleCols(i0 * c, nb * c).transpose() * minus_w;
    for (int j = 0; j < L; ++j) xj[j] = x_filt->row(k0 + j + 1).data() + i0 * c;
    DispatchShape(c, d, [&](auto C, auto) {
      CoupledSweep<decltype(C)::value>(c, nb, L, Fc_.data() + i0 * c * c, EW.data(), xj.data());
    });
  }
}

}  // namespace kfx::detail
