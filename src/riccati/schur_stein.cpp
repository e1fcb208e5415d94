// Stein equations on the real Schur form (declarations: schur_stein.hpp): DGEES once, then a
// recursive blocked Bartels-Stewart solve on the quasi-triangular factors. Splitting T (or S) in two
// leaves two smaller equations of the same kind coupled by one matrix product; blocks of size <= kBase
// are solved by the classical column-by-column substitution with 1 x 1 .. 4 x 4 Kronecker systems.
#include "riccati/schur_stein.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "base/lapack_fortran.hpp"

namespace kfx::detail {

namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using MatRef = Eigen::Ref<MatrixXd>;

constexpr Index kBase = 32;

// 2 when the diagonal block of the quasi-triangular T starting at i is a 2 x 2 block, else 1.
Index BlockSize(const ConstRef& T, Index i) { return (i + 1 < T.rows() && T(i + 1, i) != 0.0) ? 2 : 1; }

// k moved past a 2 x 2 block it would cut.
Index Split(const ConstRef& T, Index k) { return (k > 0 && k < T.rows() && T(k, k - 1) != 0.0) ? k + 1 : k; }

std::vector<Index> BlockStarts(const ConstRef& T) {
  std::vector<Index> starts;
  for (Index i = 0; i < T.rows(); i += BlockSize(T, i)) starts.push_back(i);
  return starts;
}

// Solves M x = b (m <= 4) by Gaussian elimination with complete pivoting; a pivot below
// 64 eps max|M| is replaced by that value (as LAPACK's DLASY2 does with eps) and false is returned: the
// equation is singular to working precision (1 - lambda_i mu_j of that order).
bool SolveSmall(int m, double M[4][4], double* b) {
  const double eps = std::numeric_limits<double>::epsilon();
  double big = 0.0;
  for (int i = 0; i < m; ++i)
    for (int j = 0; j < m; ++j) big = std::max(big, std::abs(M[i][j]));
  const double smin = std::max(64 * eps * big, std::numeric_limits<double>::min());
  int col[4] = {0, 1, 2, 3};
  bool ok = true;
  for (int k = 0; k < m; ++k) {
    int pi = k, pj = k;
    for (int i = k; i < m; ++i)
      for (int j = k; j < m; ++j)
        if (std::abs(M[i][j]) > std::abs(M[pi][pj])) pi = i, pj = j;
    if (pi != k) {
      for (int j = 0; j < m; ++j) std::swap(M[k][j], M[pi][j]);
      std::swap(b[k], b[pi]);
    }
    if (pj != k) {
      for (int i = 0; i < m; ++i) std::swap(M[i][k], M[i][pj]);
      std::swap(col[k], col[pj]);
    }
    if (std::abs(M[k][k]) < smin) {
      M[k][k] = smin;
      ok = false;
    }
    for (int i = k + 1; i < m; ++i) {
      const double f = M[i][k] / M[k][k];
      for (int j = k + 1; j < m; ++j) M[i][j] -= f * M[k][j];
      b[i] -= f * b[k];
    }
  }
  double x[4];
  for (int k = m - 1; k >= 0; --k) {
    double s = b[k];
    for (int j = k + 1; j < m; ++j) s -= M[k][j] * x[j];
    x[k] = s / M[k][k];
  }
  for (int k = 0; k < m; ++k) b[col[k]] = x[k];
  return ok;
}

// Y = T Y S^T + F for small T, S: column blocks J of S from the last, within each the row blocks I of
// T from the last; Y_IJ - T_II Y_IJ S_JJ^T = F_IJ + (the terms of the blocks already solved).
bool SteinBase(const ConstRef& T, const ConstRef& S, MatRef F) {
  const Index p = T.rows(), q = S.rows();
  const std::vector<Index> rows = BlockStarts(T), cols = BlockStarts(S);
  std::vector<double> w(static_cast<size_t>(p));
  bool ok = true;
  for (auto jt = cols.rbegin(); jt != cols.rend(); ++jt) {
    const Index J = *jt, sJ = BlockSize(S, J);
    // F(:, J+b) += T (sum_{l after the block} Y(:, l) S(J+b, l)).
    for (Index b = 0; b < sJ && J + sJ < q; ++b) {
      for (Index i = 0; i < p; ++i) {
        double s = 0.0;
        for (Index l = J + sJ; l < q; ++l) s += F(i, l) * S(J + b, l);
        w[static_cast<size_t>(i)] = s;
      }
      for (Index i = 0; i < p; ++i) {
        double s = 0.0;
        for (Index k = std::max<Index>(i - 1, 0); k < p; ++k) s += T(i, k) * w[static_cast<size_t>(k)];
        F(i, J + b) += s;
      }
    }
    for (auto it = rows.rbegin(); it != rows.rend(); ++it) {
      const Index I = *it, sI = BlockSize(T, I);
      double g[2][2] = {{0.0, 0.0}, {0.0, 0.0}};  // sum_{k after the block} T(I+a, k) Y(k, J+c)
      for (Index a = 0; a < sI; ++a)
        for (Index c = 0; c < sJ; ++c)
          for (Index k = I + sI; k < p; ++k) g[a][c] += T(I + a, k) * F(k, J + c);
      double M[4][4], rhs[4];
      const int m = static_cast<int>(sI * sJ);
      for (Index b = 0; b < sJ; ++b) {
        for (Index a = 0; a < sI; ++a) {
          double r = F(I + a, J + b);
          for (Index c = 0; c < sJ; ++c) r += g[a][c] * S(J + b, J + c);
          rhs[a + sI * b] = r;
          for (Index d = 0; d < sJ; ++d)
            for (Index c = 0; c < sI; ++c)
              M[a + sI * b][c + sI * d] = (a == c && b == d ? 1.0 : 0.0) - T(I + a, I + c) * S(J + b, J + d);
        }
      }
      ok = SolveSmall(m, M, rhs) && ok;
      for (Index b = 0; b < sJ; ++b)
        for (Index a = 0; a < sI; ++a) F(I + a, J + b) = rhs[a + sI * b];
    }
  }
  return ok;
}

// W = Y S^T for S upper quasi-triangular (DTRMM and the subdiagonal entries).
void TimesQuasiUpperTransposed(const ConstRef& Y, const ConstRef& S, MatrixXd* W) {
  W->noalias() = Y * S.triangularView<Eigen::Upper>().transpose();
  for (Index i = 0; i + 1 < S.rows(); ++i)
    if (S(i + 1, i) != 0.0) W->col(i + 1) += S(i + 1, i) * Y.col(i);
}

// W = T Y for T upper quasi-triangular.
void QuasiUpperTimes(const ConstRef& T, const ConstRef& Y, MatrixXd* W) {
  W->noalias() = T.triangularView<Eigen::Upper>() * Y;
  for (Index i = 0; i + 1 < T.rows(); ++i)
    if (T(i + 1, i) != 0.0) W->row(i + 1) += T(i + 1, i) * Y.row(i);
}

bool SteinRecursive(const ConstRef& T, const ConstRef& S, MatRef F) {
  const Index p = T.rows(), q = S.rows();
  if (p == 0 || q == 0) return true;
  if (p <= kBase && q <= kBase) return SteinBase(T, S, F);
  MatrixXd W;
  if (p >= q) {
    // Rows [Y1; Y2]: Y2 = T22 Y2 S^T + F2; Y1 = T11 Y1 S^T + (F1 + T12 Y2 S^T).
    const Index k = Split(T, p / 2);
    bool ok = SteinRecursive(T.bottomRightCorner(p - k, p - k), S, F.bottomRows(p - k));
    TimesQuasiUpperTransposed(F.bottomRows(p - k), S, &W);
    F.topRows(k).noalias() += T.topRightCorner(k, p - k) * W;
    return SteinRecursive(T.topLeftCorner(k, k), S, F.topRows(k)) && ok;
  }
  // Columns [Y_1, Y_2]: Y_2 = T Y_2 S22^T + F_2; Y_1 = T Y_1 S11^T + (F_1 + T Y_2 S12^T).
  const Index k = Split(S, q / 2);
  bool ok = SteinRecursive(T, S.bottomRightCorner(q - k, q - k), F.rightCols(q - k));
  QuasiUpperTimes(T, F.rightCols(q - k), &W);
  F.leftCols(k).noalias() += W * S.topRightCorner(k, q - k).transpose();
  return SteinRecursive(T, S.topLeftCorner(k, k), F.leftCols(k)) && ok;
}

// F11 += M T12^T + T12 M^T (DSYR2K on the lower triangle, mirrored).
void AddSymmetricRank2k(const MatrixXd& M, const ConstRef& T12, MatRef F11) {
  const int k = FortranInt(M.rows()), r = FortranInt(M.cols());
  const int ldm = std::max(1, k), ldt = FortranInt(std::max<Index>(1, T12.outerStride()));
  const int ldf = FortranInt(std::max<Index>(1, F11.outerStride()));
  const double one = 1.0;
  dsyr2k_("L", "N", &k, &r, &one, M.data(), &ldm, T12.data(), &ldt, &one, F11.data(), &ldf);
  F11.triangularView<Eigen::StrictlyUpper>() = F11.transpose();
}

bool LyapunovRecursive(const ConstRef& T, MatRef F) {
  const Index n = T.rows();
  if (n == 0) return true;
  if (n <= kBase) {
    const bool ok = SteinBase(T, T, F);
    for (Index j = 0; j < n; ++j)
      for (Index i = 0; i < j; ++i) F(i, j) = F(j, i) = 0.5 * (F(i, j) + F(j, i));
    return ok;
  }
  // [[Y11, Y12], [Y12^T, Y22]]: Y22 = T22 Y22 T22^T + F22;
  // Y12 = T11 Y12 T22^T + (F12 + T12 Y22 T22^T);
  // Y11 = T11 Y11 T11^T + (F11 + M T12^T + T12 M^T),  M = T11 Y12 + T12 Y22 / 2.
  const Index k = Split(T, n / 2), r = n - k;
  const ConstRef T11 = T.topLeftCorner(k, k), T12 = T.topRightCorner(k, r), T22 = T.bottomRightCorner(r, r);
  bool ok = LyapunovRecursive(T22, F.bottomRightCorner(r, r));
  const MatrixXd P = T12 * F.bottomRightCorner(r, r);  // T12 Y22
  MatrixXd W;
  TimesQuasiUpperTransposed(P, T22, &W);
  F.topRightCorner(k, r) += W;
  ok = SteinRecursive(T11, T22, F.topRightCorner(k, r)) && ok;
  MatrixXd M;
  QuasiUpperTimes(T11, F.topRightCorner(k, r), &M);
  M += 0.5 * P;
  AddSymmetricRank2k(M, T12, F.topLeftCorner(k, k));
  ok = LyapunovRecursive(T11, F.topLeftCorner(k, k)) && ok;
  F.bottomLeftCorner(r, k) = F.topRightCorner(k, r).transpose();
  return ok;
}

}  // namespace

double RealSchur::SpectralRadius() const { return eigenvalues.size() == 0 ? 0.0 : eigenvalues.cwiseAbs().maxCoeff(); }

RealSchur ComputeRealSchur(const ConstRef& A) {
  RealSchur out;
  const int n = FortranInt(A.rows());
  out.T = A;
  out.U.resize(n, n);
  out.eigenvalues.resize(n);
  if (n == 0) return out;
  std::vector<double> wr(static_cast<size_t>(n)), wi(static_cast<size_t>(n));
  int sdim = 0, info = 0, lwork = -1;
  double query = 0.0;
  dgees_("V", "N", nullptr, &n, out.T.data(), &n, &sdim, wr.data(), wi.data(), out.U.data(), &n, &query, &lwork,
         nullptr, &info, 1, 1);
  lwork = std::max(static_cast<int>(query), 3 * n);
  std::vector<double> work(static_cast<size_t>(lwork));
  dgees_("V", "N", nullptr, &n, out.T.data(), &n, &sdim, wr.data(), wi.data(), out.U.data(), &n, work.data(), &lwork,
         nullptr, &info, 1, 1);
  out.info = info;
  for (int i = 0; i < n; ++i) out.eigenvalues(i) = {wr[static_cast<size_t>(i)], wi[static_cast<size_t>(i)]};
  // Exact zeros below the quasi-triangle (DGEES leaves them zero; the solvers read the subdiagonal only).
  return out;
}

bool SolveQuasiTriangularStein(const ConstRef& T, const ConstRef& S, Eigen::Ref<MatrixXd> F) {
  KFX_ASSERT(T.rows() == T.cols() && S.rows() == S.cols() && F.rows() == T.rows() && F.cols() == S.rows());
  return SteinRecursive(T, S, F);
}

bool SolveQuasiTriangularLyapunov(const ConstRef& T, Eigen::Ref<MatrixXd> F) {
  KFX_ASSERT(T.rows() == T.cols() && F.rows() == T.rows() && F.cols() == T.rows());
  return LyapunovRecursive(T, F);
}

bool SolveLyapunovBySchur(const RealSchur& a, const ConstRef& Q, MatrixXd* X) {
  const Index n = a.T.rows();
  const MatrixXd Ut = a.U.transpose();
  MatrixXd F = MatrixXd::Zero(n, n);
  UpdateWithCongruence(Ut, Q, 1.0, 0.0, &F);  // U^T Q U
  const bool ok = LyapunovRecursive(a.T, F);
  X->setZero(n, n);
  UpdateWithCongruence(a.U, F, 1.0, 0.0, X);  // U Y U^T
  return ok;
}

bool SolveSteinBySchur(const RealSchur& a, const RealSchur& b, const ConstRef& F, MatrixXd* Y) {
  MatrixXd G = a.U.transpose() * F * b.U;
  const bool ok = SteinRecursive(a.T, b.T, G);
  *Y = a.U * G * b.U.transpose();
  return ok;
}

}  // namespace kfx::detail
