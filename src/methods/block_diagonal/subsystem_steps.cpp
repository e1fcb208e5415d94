// The per-subsystem Kalman steps of 004's block-diagonal and banded filters (L = F P F^T + Q,
// M = H L H^T + R, J = L H^T M^{-1}, P = L - J H L, and the Cholesky inverse of M), for a range of
// subsystems: the fixed-shape instances for the common (c, d) and the generic ones. Pass 1 of the
// O(n r^2) step (block_diagonal_passes.cpp) and the banded step (reference_steps.cpp) call them.
#include <cmath>
#include <string>

#include "kfx/block_diagonal.hpp"
#include "kfx/error.hpp"
#include "methods/block_diagonal/block_diagonal_internal.hpp"
#include "methods/block_diagonal/block_diagonal_shared.hpp"

namespace kfx::detail {

using Eigen::Index;
using Eigen::MatrixXd;

namespace {

// Small per-block matrices live on the stack (no allocation per block) up to 8 x 8.
constexpr int kMaxSmall = 8;
using Small = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxSmall, kMaxSmall>;

// Block i of a packed matrix as the (fixed-size when possible) type Mat, and back.
template <typename Mat>
Mat LoadBlock(const MatrixXd& m, Index i, Index cols) {
  if constexpr (Mat::RowsAtCompileTime != Eigen::Dynamic && Mat::ColsAtCompileTime != Eigen::Dynamic) {
    constexpr int R = Mat::RowsAtCompileTime, C = Mat::ColsAtCompileTime;
    return Eigen::Map<const Eigen::Matrix<double, R, C>>(m.data() + i * cols * m.rows());  // column-major
  } else {
    return BlockOf(m, i, cols);
  }
}
template <typename Expr>
void StoreBlock(const Expr& e, MatrixXd& m, Index i, Index cols) {
  constexpr int R = Expr::RowsAtCompileTime, C = Expr::ColsAtCompileTime;
  if constexpr (R != Eigen::Dynamic && C != Eigen::Dynamic) {
    Eigen::Map<Eigen::Matrix<double, R, C>>(m.data() + i * cols * m.rows()) = e;  // default: column-major storage
  } else {
    BlockOf(m, i, cols) = e;
  }
}

// The per-subsystem Kalman step shared by the block-diagonal filter (Q = V: eqs. (9), (14), (15))
// and the banded filter (Q = D{V + G U G^T}) for subsystems [i0, i1): L = F P F^T + Q,
// M = H L H^T + R = R_c^T R_c (Cholesky), J = L H^T M^{-1} (the banded gain), P_out = L - J H L,
// and, when asked for, R_c^{-1} (d x d upper triangular, so M^{-1} = R_c^{-1} R_c^{-T}) into
// rinv[(i - i0) d^2 ...]. MatC, MatD, MatDC are c x c, d x d, d x c types: fixed-size for the
// common shapes, stack-allocated dynamic for c, d <= 8, heap-allocated beyond.
template <typename MatC, typename MatD, typename MatDC>
void SubsystemKalmanSteps(const CoupledStep& s, const MatrixXd& Pp, const MatrixXd& Q, Index i0, Index i1, double* rinv,
                          MatrixXd& J, MatrixXd& P_out) {
  const Index c = s.c(), d = s.d();
  for (Index i = i0; i < i1; ++i) {
    const MatC F = LoadBlock<MatC>(s.F, i, c);
    const MatDC H = LoadBlock<MatDC>(s.H, i, c);
    MatC L = F.lazyProduct(LoadBlock<MatC>(Pp, i, c)).lazyProduct(F.transpose()) + LoadBlock<MatC>(Q, i, c);
    L = (0.5 * (L + L.transpose())).eval();
    const MatDC HL = H * L;
    const MatD M = HL * H.transpose() + LoadBlock<MatD>(s.R, i, d);
    MatDC Jt;  // M^{-1} H L = J^T
    if constexpr (MatD::RowsAtCompileTime == 1) {
      const double m = M(0, 0);
      if (!(m > 0.0) || !std::isfinite(m)) {
        throw NumericalError("M (block " + std::to_string(i) + "): H L H^T + R is not positive");
      }
      Jt = HL / m;
      if (rinv) rinv[i - i0] = 1.0 / std::sqrt(m);
      StoreBlock(Jt.transpose(), J, i, d);
      const MatC A = L - Jt.transpose() * HL;
      StoreBlock(0.5 * (A + A.transpose()), P_out, i, c);
      continue;
    }
    const Eigen::LLT<MatD> llt(M);
    if (llt.info() != Eigen::Success) {
      throw NumericalError("M (block " + std::to_string(i) + "): H L H^T + R is not positive definite");
    }
    if constexpr (MatD::RowsAtCompileTime != Eigen::Dynamic) {
      // Fixed d <= 4: closed-form inverse of the Cholesky factor (no BLAS call per subsystem; with
      // EIGEN_USE_BLAS every triangular solve would be a DTRSM call with its locking overhead).
      const MatD Rinv = MatD(llt.matrixL()).inverse().transpose();  // R_c^{-1}, M = R_c^T R_c
      Jt.noalias() = Rinv * (Rinv.transpose() * HL);
      if (rinv) Eigen::Map<MatD>(rinv + (i - i0) * d * d) = Rinv;
    } else {
      Jt = llt.solve(HL);
      if (rinv) {
        Eigen::Map<MatrixXd>(rinv + (i - i0) * d * d, d, d) = llt.matrixU().solve(MatD::Identity(d, d));
      }
    }
    StoreBlock(Jt.transpose(), J, i, d);
    const MatC A = L - Jt.transpose() * HL;
    StoreBlock(0.5 * (A + A.transpose()), P_out, i, c);
  }
}

// The same step for d = 1 and c = C fixed, as plain scalar loops (about twice faster per subsystem
// than the fixed-size Eigen expressions above at c = 2, which the compiler did not fully inline).
template <int C>
void ScalarMeasurementKalmanSteps(const CoupledStep& s, const MatrixXd& Pp, const MatrixXd& Q, Index i0, Index i1,
                                  double* rinv, MatrixXd& J, MatrixXd& P_out) {
  for (Index i = i0; i < i1; ++i) {
    const double* f = s.F.data() + i * C * C;
    const double* p = Pp.data() + i * C * C;
    const double* q = Q.data() + i * C * C;
    const double* h = s.H.data() + i * C;
    double fp[C * C], L[C * C], hl[C], jt[C];
    for (int b = 0; b < C; ++b)
      for (int a = 0; a < C; ++a) {
        double acc = 0.0;
        for (int t = 0; t < C; ++t) acc += f[t * C + a] * p[b * C + t];
        fp[b * C + a] = acc;  // (F P)(a, b)
      }
    for (int b = 0; b < C; ++b)
      for (int a = 0; a < C; ++a) {
        double acc = 0.0;
        for (int t = 0; t < C; ++t) acc += fp[t * C + a] * f[t * C + b];
        L[b * C + a] = acc + q[b * C + a];  // (F P F^T + Q)(a, b)
      }
    for (int b = 0; b < C; ++b)
      for (int a = b + 1; a < C; ++a) L[b * C + a] = L[a * C + b] = 0.5 * (L[b * C + a] + L[a * C + b]);
    double m = s.R.data()[i];
    for (int b = 0; b < C; ++b) {
      double acc = 0.0;
      for (int a = 0; a < C; ++a) acc += h[a] * L[b * C + a];
      hl[b] = acc;  // (H L)(b)
      m += acc * h[b];
    }
    if (!(m > 0.0) || !std::isfinite(m)) {
      throw NumericalError("M (block " + std::to_string(i) + "): H L H^T + R is not positive");
    }
    for (int b = 0; b < C; ++b) jt[b] = hl[b] / m;
    if (rinv) rinv[i - i0] = 1.0 / std::sqrt(m);
    double* j = J.data() + i * C;
    double* po = P_out.data() + i * C * C;
    for (int b = 0; b < C; ++b) {
      j[b] = jt[b];
      for (int a = 0; a <= b; ++a) {
        po[b * C + a] = po[a * C + b] =
            0.5 * ((L[b * C + a] - jt[a] * hl[b]) + (L[a * C + b] - jt[b] * hl[a]));  // L - J H L, symmetrized
      }
    }
  }
}

}  // namespace

void SubsystemKalmanSteps(const CoupledStep& s, const MatrixXd& Pp, const MatrixXd& Q, Index i0, Index i1, double* rinv,
                          MatrixXd& J, MatrixXd& P_out) {
  using Eigen::Matrix;
  const Index c = s.c(), d = s.d();
  if (!detail::SpecializedKernels()) {
    if (c <= kMaxSmall && d <= kMaxSmall) {
      SubsystemKalmanSteps<Small, Small, Small>(s, Pp, Q, i0, i1, rinv, J, P_out);
    } else {
      SubsystemKalmanSteps<MatrixXd, MatrixXd, MatrixXd>(s, Pp, Q, i0, i1, rinv, J, P_out);
    }
  } else if (c == 1 && d == 1) {
    ScalarMeasurementKalmanSteps<1>(s, Pp, Q, i0, i1, rinv, J, P_out);
  } else if (c == 2 && d == 1) {
    ScalarMeasurementKalmanSteps<2>(s, Pp, Q, i0, i1, rinv, J, P_out);
  } else if (c == 3 && d == 1) {
    ScalarMeasurementKalmanSteps<3>(s, Pp, Q, i0, i1, rinv, J, P_out);
  } else if (c == 4 && d == 1) {
    ScalarMeasurementKalmanSteps<4>(s, Pp, Q, i0, i1, rinv, J, P_out);
  } else if (c == 2 && d == 2) {
    SubsystemKalmanSteps<Eigen::Matrix2d, Eigen::Matrix2d, Eigen::Matrix2d>(s, Pp, Q, i0, i1, rinv, J, P_out);
  } else if (c <= kMaxSmall && d <= kMaxSmall) {
    SubsystemKalmanSteps<Small, Small, Small>(s, Pp, Q, i0, i1, rinv, J, P_out);
  } else {
    SubsystemKalmanSteps<MatrixXd, MatrixXd, MatrixXd>(s, Pp, Q, i0, i1, rinv, J, P_out);
  }
}

}  // namespace kfx::detail
