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
#include <utility>
#include <vector>

#include "kfx/block_diagonal.hpp"
#include "kfx/error.hpp"
#include "methods/block_diagonal/block_diagonal_shared.hpp"

namespace kfx::detail {

using Eigen::Index;
using Eigen::MatrixXd;

FrozenBlockDiagonal::FrozenBlockDiagonal(const CoupledStep& s, const MatrixXd& P_filt, int group) : group_(group) {
  KFX_ASSERT(group >= 1);
  BlockDiagonalCovarianceStep st;
  BlockDiagonalCovarianceUpdate(s, P_filt, &st);  // the gain of the next step from the converged P
  gain_ = std::move(st.gain);
  const Index n = s.n(), c = s.c(), d = s.d(), r = s.r();
  F_ = s.F;
  H_ = s.H;
  Fc_.resize(c, n * c);
  MatrixXd HF(d, n * c);
  for (Index i = 0; i < n; ++i) {
    const Eigen::Ref<const MatrixXd> F = s.F.middleCols(i * c, c);
    HF.middleCols(i * c, c).noalias() = s.H.middleCols(i * c, c) * F;
    Fc_.middleCols(i * c, c) = F;
    Fc_.middleCols(i * c, c).noalias() -= gain_.J.middleCols(i * d, d) * HF.middleCols(i * c, c);
  }
  // M_m, m = 0..group-2, in chunks: V_i = H_i F_i Fc_i^m (d x c), Z_i = E_i^T V_i^T (r x d), M_m += Y_i^T Z_i^T.
  M_.assign(static_cast<size_t>(std::max(group - 1, 0)), MatrixXd::Zero(r, r));
  if (r == 0) return;
  constexpr Index kChunk = 4096;
  MatrixXd Z(r, kChunk * d), V;
  for (Index i0 = 0; i0 < n; i0 += kChunk) {
    const Index nb = std::min(kChunk, n - i0);
    V = HF.middleCols(i0 * c, nb * c);
    for (int m = 0; m + 1 < group; ++m) {
      for (Index i = 0; i < nb; ++i) {
        Z.middleCols(i * d, d).noalias() = gain_.Et.middleCols((i0 + i) * c, c) * V.middleCols(i * c, c).transpose();
      }
      M_[static_cast<size_t>(m)].noalias() += gain_.Yt.middleCols(i0 * d, nb * d) * Z.leftCols(nb * d).transpose();
      for (Index i = 0; i < nb; ++i)
        V.middleCols(i * c, c) = (V.middleCols(i * c, c) * Fc_.middleCols((i0 + i) * c, c)).eval();
    }
  }
}

void FrozenBlockDiagonal::Run(const TimeSeries& y, int k0, int L, TimeSeries* x_filt, TimeSeries* coupling) const {
  KFX_ASSERT(L >= 1 && L <= group_);
  const Index c = F_.rows(), d = H_.rows(), r = gain_.C1.rows(), n = c > 0 ? F_.cols() / c : 0;
  // Sweep 1: the local parts a_j into rows k0 + j, and s_j = sum_i Y_i^T nu_a (r x L).
  MatrixXd S = MatrixXd::Zero(r, L);
  std::vector<double> a(static_cast<size_t>(c)), fa(static_cast<size_t>(c)), nu(static_cast<size_t>(d));
  const double* Fd = F_.data();
  const double* Hd = H_.data();
  const double* Jd = gain_.J.data();
  const double* Yd = gain_.Yt.data();
  const double* Ed = gain_.Et.data();
  const double* Fcd = Fc_.data();
  for (Index i = 0; i < n; ++i) {
    const double* Fi = Fd + i * c * c;  // column-major c x c
    const double* Hi = Hd + i * d * c;
    const double* Ji = Jd + i * c * d;
    const double* Yi = Yd + i * d * r;  // Y_i^T: r x d, column-major
    for (Index p = 0; p < c; ++p) a[p] = (*x_filt)(k0, i * c + p);
    for (int j = 1; j <= L; ++j) {
      for (Index p = 0; p < c; ++p) {
        double acc = 0.0;
        for (Index q = 0; q < c; ++q) acc += Fi[q * c + p] * a[q];
        fa[p] = acc;
      }
      for (Index e = 0; e < d; ++e) {
        double acc = y(k0 + j - 1, i * d + e);
        for (Index q = 0; q < c; ++q) acc -= Hi[q * d + e] * fa[q];
        nu[e] = acc;
      }
      double* out = x_filt->row(k0 + j).data() + i * c;
      for (Index p = 0; p < c; ++p) {
        double acc = fa[p];
        for (Index e = 0; e < d; ++e) acc += Ji[e * c + p] * nu[e];
        a[p] = acc;
        out[p] = acc;
      }
      double* sj = S.col(j - 1).data();
      for (Index e = 0; e < d; ++e) {
        const double* ye = Yi + e * r;
        const double v = nu[e];
        for (Index t = 0; t < r; ++t) sj[t] += ye[t] * v;
      }
    }
  }
  if (r == 0) return;  // no coupling: nothing below (and no products of empty matrices)
  // The r-dimensional recursion: w_j = C_1 (s_j + sum_{l<j} M_{j-1-l} w_l) = mu_u of step k0 + j.
  MatrixXd Wm(r, L);
  for (int j = 1; j <= L; ++j) {
    Eigen::VectorXd v = S.col(j - 1);
    for (int l = 1; l < j; ++l) v.noalias() += M_[static_cast<size_t>(j - 1 - l)] * Wm.col(l - 1);
    Wm.col(j - 1).noalias() = gain_.C1 * v;
    if (coupling) coupling->row(k0 + j - 1) = Wm.col(j - 1).transpose();
  }
  // Sweep 2: b_j = Fc b_{j-1} - E_i w_j added to rows k0 + j.
  std::vector<double> b(static_cast<size_t>(c)), nb(static_cast<size_t>(c));
  for (Index i = 0; i < n; ++i) {
    const double* Fci = Fcd + i * c * c;
    const double* Ei = Ed + i * c * r;  // E_i^T: r x c, column-major (column p: row p of E_i)
    std::fill(b.begin(), b.end(), 0.0);
    for (int j = 1; j <= L; ++j) {
      const double* w = Wm.col(j - 1).data();
      double* out = x_filt->row(k0 + j).data() + i * c;
      for (Index p = 0; p < c; ++p) {
        double acc = 0.0;
        for (Index q = 0; q < c; ++q) acc += Fci[q * c + p] * b[q];
        const double* ep = Ei + p * r;
        double ew = 0.0;
        for (Index t = 0; t < r; ++t) ew += ep[t] * w[t];
        nb[p] = acc - ew;
      }
      for (Index p = 0; p < c; ++p) {
        b[p] = nb[p];
        out[p] += b[p];
      }
    }
  }
}

}  // namespace kfx::detail
