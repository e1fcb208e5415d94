#pragma once
// The arithmetic of one kfx.KalmanFilter step (filterpy_kalman_filter.cpp), templated on the matrix type:
// compile-time-bounded matrices for n, m <= kSmallMax, dynamic ones above.
#include <Eigen/Dense>
#include <vector>

#include "filterpy_kalman_filter.hpp"

namespace kfx::python::filterpy {

template <typename Mat>
void SymmetrizeInPlace(Mat& S) {
  for (Eigen::Index i = 0; i < S.rows(); ++i) {
    for (Eigen::Index j = i + 1; j < S.cols(); ++j) {
      const double v = 0.5 * (S(i, j) + S(j, i));
      S(i, j) = v;
      S(j, i) = v;
    }
  }
}

// K = B S^-1 for S = L L^T (L: the lower triangle of `llt`), row by row: K_i^T solves L L^T k = B_i^T.
// Plain substitution: at the sizes of a FilterPy filter a BLAS triangular solve costs more in its call.
template <typename Mat>
void CholeskySolveRows(const Mat& llt, const Mat& B, Mat& K) {
  const Eigen::Index m = llt.rows();
  K.resize(B.rows(), m);
  for (Eigen::Index r = 0; r < B.rows(); ++r) {
    for (Eigen::Index i = 0; i < m; ++i) {  // L v = b
      double v = B(r, i);
      for (Eigen::Index j = 0; j < i; ++j) v -= llt(i, j) * K(r, j);
      K(r, i) = v / llt(i, i);
    }
    for (Eigen::Index i = m - 1; i >= 0; --i) {  // L^T k = v
      double v = K(r, i);
      for (Eigen::Index j = i + 1; j < m; ++j) v -= llt(j, i) * K(r, j);
      K(r, i) = v / llt(i, i);
    }
  }
}

// Up to this size the steps run on matrices with a compile-time maximum size (no heap allocation, Eigen's
// coefficient-based products): most of a FilterPy filter's time at n = 4 is otherwise call overhead.
constexpr Eigen::Index kSmallMax = 8;
using SmallMat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor, kSmallMax, kSmallMax>;

// x_out = F x + bu, P_out = a2 F P F^T + Q (symmetrized).
template <typename Mat>
void PredictKernel(const CRef& x, const CRef& P, const CRef& F, const CRef& Q, const Eigen::VectorXd& bu, double a2,
                   RowMat& x_out, RowMat& P_out) {
  const Mat Fm = F, Pm = P, xm = x;
  Mat xo = Fm * xm;
  if (bu.size() != 0) xo += bu;
  const Mat FP = Fm * Pm;
  Mat Po = FP * Fm.transpose();
  if (a2 != 1.0) Po *= a2;
  Po += Q;
  SymmetrizeInPlace(Po);
  x_out = xo;
  P_out = Po;
}

// The update of (x, P) with rows `obs` of (z, H, R) (M: the cross-covariance, may be null). With
// B = P H^T + M: S = H B + M^T H^T + R, K = B S^-1, and Joseph's form (I - K H) P (I - K H)^T + K R K^T
// [- (I - K H) M K^T - K M^T (I - K H)^T] expanded, P - K B^T + (K S - B) K^T: exact for any K, first-order
// insensitive to an error in K as the product form is, in O(n^2 m) instead of O(n^3). False when S is not
// positive definite.
template <typename Mat>
bool CorrectKernel(const CRef& x, const CRef& P, const Eigen::VectorXd& z, const CRef& H, const CRef& R,
                   const RowMat* M, const std::vector<Eigen::Index>& obs, bool joseph, RowMat& x_out, RowMat& P_out,
                   RowMat& y_out, RowMat& S_out, RowMat& K_out) {
  const Eigen::Index n = P.rows(), k = static_cast<Eigen::Index>(obs.size());
  Mat Hs(k, n), Rs(k, k), y(k, 1), Ms;
  for (Eigen::Index i = 0; i < k; ++i) {
    Hs.row(i) = H.row(obs[i]);
    y(i, 0) = z(obs[i]);
    for (Eigen::Index j = 0; j < k; ++j) Rs(i, j) = R(obs[i], obs[j]);
  }
  const Mat Pm = P, xm = x;
  y.noalias() -= Hs * xm;
  Mat B = Pm * Hs.transpose();
  Mat S = Hs * B;
  S += Rs;
  if (M) {
    Ms.resize(n, k);
    for (Eigen::Index i = 0; i < k; ++i) Ms.col(i) = M->col(obs[i]);
    S.noalias() += Hs * Ms;
    S.noalias() += Ms.transpose() * Hs.transpose();
    B += Ms;
  }
  SymmetrizeInPlace(S);
  const Eigen::LLT<Mat> llt(S);
  if (llt.info() != Eigen::Success) return false;
  Mat K;
  CholeskySolveRows<Mat>(llt.matrixLLT(), B, K);
  Mat xo = xm;
  xo.noalias() += K * y;
  Mat Po = Pm;
  Po.noalias() -= K * B.transpose();
  if (joseph) {
    Mat T = -B;
    T.noalias() += K * S;
    Po.noalias() += T * K.transpose();
  }
  SymmetrizeInPlace(Po);
  x_out = xo;
  P_out = Po;
  y_out = y;
  S_out = S;
  K_out = K;
  return true;
}

}  // namespace kfx::python::filterpy
