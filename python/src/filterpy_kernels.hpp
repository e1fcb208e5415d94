#pragma once
// The arithmetic of one kfx.KalmanFilter step (filterpy_kalman_filter.cpp), templated on the matrix type:
// compile-time-bounded matrices for n, m <= kSmallMax, dynamic ones above.
#include <Eigen/Dense>
#include <type_traits>
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

// Up to this size the steps run on matrices with a compile-time maximum size (no heap allocation) and the
// products below: most of a FilterPy filter's time at n = 4 is otherwise call overhead.
constexpr Eigen::Index kSmallMax = 8;
using SmallMat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor, kSmallMax, kSmallMax>;

// c = a op(b), c += a op(b) or c -= a op(b), op(b) = b or b^T; a, b row-major (a matrix or a Ref), c a
// RowMat or SmallMat that aliases neither. With Mat = SmallMat as plain loops: Eigen's products of matrices
// whose size is known only at run time evaluate these coefficient by coefficient through calls that cost
// more than the arithmetic (3x the loops' time for a predict + update at n = 4, bench/python_overhead.py).
enum class Acc { kSet, kAdd, kSub };
template <typename Mat, bool transpose_b, Acc acc, typename A, typename B, typename C>
void Product(const A& a, const B& b, C& c) {
  if constexpr (std::is_same_v<Mat, SmallMat>) {
    const Eigen::Index r = a.rows(), k = a.cols(), cols = transpose_b ? b.rows() : b.cols();
    const Eigen::Index sa = a.outerStride(), sb = b.outerStride();
    if constexpr (acc == Acc::kSet) c.resize(r, cols);
    const double *pa = a.data(), *pb = b.data();
    double* out = c.data();
    for (Eigen::Index i = 0; i < r; ++i) {
      for (Eigen::Index j = 0; j < cols; ++j) {
        double s = 0.0;
        if constexpr (transpose_b) {
          for (Eigen::Index l = 0; l < k; ++l) s += pa[i * sa + l] * pb[j * sb + l];
        } else {
          for (Eigen::Index l = 0; l < k; ++l) s += pa[i * sa + l] * pb[l * sb + j];
        }
        double& o = out[i * cols + j];
        if constexpr (acc == Acc::kSet) o = s;
        if constexpr (acc == Acc::kAdd) o += s;
        if constexpr (acc == Acc::kSub) o -= s;
      }
    }
  } else if constexpr (transpose_b) {
    if constexpr (acc == Acc::kSet) c.noalias() = a * b.transpose();
    if constexpr (acc == Acc::kAdd) c.noalias() += a * b.transpose();
    if constexpr (acc == Acc::kSub) c.noalias() -= a * b.transpose();
  } else {
    if constexpr (acc == Acc::kSet) c.noalias() = a * b;
    if constexpr (acc == Acc::kAdd) c.noalias() += a * b;
    if constexpr (acc == Acc::kSub) c.noalias() -= a * b;
  }
}

// x_out = F x + bu, P_out = a2 F P F^T + Q (symmetrized); x_out, P_out alias none of the inputs.
template <typename Mat>
void PredictKernel(const CRef& x, const CRef& P, const CRef& F, const CRef& Q, const Eigen::VectorXd& bu, double a2,
                   RowMat& x_out, RowMat& P_out) {
  Product<Mat, false, Acc::kSet>(F, x, x_out);
  if (bu.size() != 0) x_out += bu;
  Mat FP;
  Product<Mat, false, Acc::kSet>(F, P, FP);
  Product<Mat, true, Acc::kSet>(FP, F, P_out);
  if (a2 != 1.0) P_out *= a2;
  P_out += Q;
  SymmetrizeInPlace(P_out);
}

// The update of (x, P) with rows `obs` of (z, H, R) (M: the cross-covariance, may be null). With
// B = P H^T + M: S = H B + M^T H^T + R, K = B S^-1, and Joseph's form (I - K H) P (I - K H)^T + K R K^T
// [- (I - K H) M K^T - K M^T (I - K H)^T] expanded, P - K B^T + (K S - B) K^T: exact for any K, first-order
// insensitive to an error in K as the product form is, in O(n^2 m) instead of O(n^3). False when S is not
// positive definite. x_out, P_out alias none of the inputs.
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
  Mat B, S;
  Product<Mat, false, Acc::kSub>(Hs, x, y);
  Product<Mat, true, Acc::kSet>(P, Hs, B);
  Product<Mat, false, Acc::kSet>(Hs, B, S);
  S += Rs;
  if (M) {
    Ms.resize(n, k);
    for (Eigen::Index i = 0; i < k; ++i) Ms.col(i) = M->col(obs[i]);
    Mat HM;
    Product<Mat, false, Acc::kSet>(Hs, Ms, HM);
    S += HM;
    S += HM.transpose();
    B += Ms;
  }
  SymmetrizeInPlace(S);
  const Eigen::LLT<Mat> llt(S);
  if (llt.info() != Eigen::Success) return false;
  Mat K;
  CholeskySolveRows<Mat>(llt.matrixLLT(), B, K);
  x_out = x;
  Product<Mat, false, Acc::kAdd>(K, y, x_out);
  P_out = P;
  Product<Mat, true, Acc::kSub>(K, B, P_out);
  if (joseph) {
    Mat T = -B;
    Product<Mat, false, Acc::kAdd>(K, S, T);
    Product<Mat, true, Acc::kAdd>(T, K, P_out);
  }
  SymmetrizeInPlace(P_out);
  y_out = y;
  S_out = S;
  K_out = K;
  return true;
}

}  // namespace kfx::python::filterpy
