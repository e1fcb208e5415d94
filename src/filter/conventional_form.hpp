#pragma once
// Private: the conventional form of the Kalman filter (FilterForm::kConventional): P itself,
// updated by the Joseph or the standard form (CovarianceUpdateForm), in place on a per-run
// workspace. Templates over the matrix type: Eigen::MatrixXd (BLAS products, symmetric BLAS-3
// from n = 32 on) or, for n, m <= 8, matrices with a compile-time maximum size and loop kernels.
// Included by filter_form.cpp only, where the run and schedule loops are instantiated with it.
#include <Eigen/Dense>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <type_traits>
#include <vector>

#include "kfx/error.hpp"
#include "kfx/kalman_filter.hpp"
#include "kfx/validation.hpp"

namespace kfx::detail::conventional {

constexpr double kLog2Pi = 1.8378770664093454835606594728112;

// Symmetric-aware BLAS-3 products (dtrmm_, dsyr2k_ as declared by Eigen's blas.h under
// EIGEN_USE_BLAS) for n >= kSymmetricProductMin (below, Eigen's products: call
// overhead dominates). Both write the lower triangle with DSYR2K and mirror it.
constexpr Eigen::Index kSymmetricProductMin = 32;

// Small sizes (n, m <= kSmallMax) run on matrices with compile-time maximum sizes: no heap
// allocation per step, and Eigen evaluates their products coefficient by coefficient instead of
// calling BLAS (whose call overhead is most of the time at n = 4). Same formulas as the dynamic path.
constexpr int kSmallMax = 8;
using SmallMat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, kSmallMax, kSmallMax>;
using SmallVec = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, kSmallMax, 1>;

inline bool IsSmall(Eigen::Index n, Eigen::Index m) { return n <= kSmallMax && m <= kSmallMax; }

// dst = a op(b), dst += a op(b) or dst -= a op(b), op(b) = b or b^T (dst not aliased with a or
// b). Dynamic sizes: Eigen's products (BLAS from moderate sizes on). Small types: plain loops on
// the column-major storage: Eigen's coefficient-based product spends about 30 instructions per
// coefficient at n = 4, and from a maximum size of 8 on it would call GEMM.
enum class Acc { kSet, kAdd, kSub };
// c += sign a op(b) for an kRows x depth column-major a (c: kRows x cols).
template <int kRows, bool kTransB>
void SmallGemm(Eigen::Index cols, Eigen::Index depth, const double* __restrict a, Eigen::Index lda,
               const double* __restrict b, Eigen::Index ldb, double* __restrict c, Eigen::Index ldc, double sign) {
  for (Eigen::Index j = 0; j < cols; ++j) {
    double acc[kRows];
    for (int i = 0; i < kRows; ++i) acc[i] = c[i + j * ldc];
    for (Eigen::Index k = 0; k < depth; ++k) {
      const double bkj = sign * (kTransB ? b[j + k * ldb] : b[k + j * ldb]);
      for (int i = 0; i < kRows; ++i) acc[i] += a[i + k * lda] * bkj;
    }
    for (int i = 0; i < kRows; ++i) c[i + j * ldc] = acc[i];
  }
}

template <typename Mat, bool kTransB, typename D, typename L, typename R>
void Prod(D& dst, const L& a, const R& b, Acc acc) {
  if constexpr (std::is_same_v<Mat, Eigen::MatrixXd>) {
    if constexpr (kTransB) {
      if (acc == Acc::kSet) {
        dst.noalias() = a * b.transpose();
      } else if (acc == Acc::kAdd) {
        dst.noalias() += a * b.transpose();
      } else {
        dst.noalias() -= a * b.transpose();
      }
    } else {
      if (acc == Acc::kSet) {
        dst.noalias() = a * b;
      } else if (acc == Acc::kAdd) {
        dst.noalias() += a * b;
      } else {
        dst.noalias() -= a * b;
      }
    }
  } else {
    const Eigen::Index rows = a.rows(), depth = a.cols(), cols = kTransB ? b.rows() : b.cols();
    if (acc == Acc::kSet) dst.setZero(rows, cols);
    const double sign = acc == Acc::kSub ? -1.0 : 1.0;
    const Eigen::Index lda = a.rows(), ldb = b.rows(), ldc = dst.rows();
    switch (rows) {  // the row count as a compile-time constant: unrolled, vectorized columns
      case 1:
        return SmallGemm<1, kTransB>(cols, depth, a.data(), lda, b.data(), ldb, dst.data(), ldc, sign);
      case 2:
        return SmallGemm<2, kTransB>(cols, depth, a.data(), lda, b.data(), ldb, dst.data(), ldc, sign);
      case 3:
        return SmallGemm<3, kTransB>(cols, depth, a.data(), lda, b.data(), ldb, dst.data(), ldc, sign);
      case 4:
        return SmallGemm<4, kTransB>(cols, depth, a.data(), lda, b.data(), ldb, dst.data(), ldc, sign);
      case 5:
        return SmallGemm<5, kTransB>(cols, depth, a.data(), lda, b.data(), ldb, dst.data(), ldc, sign);
      case 6:
        return SmallGemm<6, kTransB>(cols, depth, a.data(), lda, b.data(), ldb, dst.data(), ldc, sign);
      case 7:
        return SmallGemm<7, kTransB>(cols, depth, a.data(), lda, b.data(), ldb, dst.data(), ldc, sign);
      case 8:
        return SmallGemm<8, kTransB>(cols, depth, a.data(), lda, b.data(), ldb, dst.data(), ldc, sign);
      default:
        return;  // rows == 0
    }
  }
}

// (S + S^T) / 2 in place: kfx::Symmetrize for dynamic sizes, inline for the small types.
template <typename Mat>
void SymmetrizeInPlace(Mat& S) {
  if constexpr (std::is_same_v<Mat, Eigen::MatrixXd>) {
    Symmetrize(S);
  } else {
    for (Eigen::Index j = 0; j < S.cols(); ++j) {
      for (Eigen::Index i = j + 1; i < S.rows(); ++i) {
        const double v = 0.5 * (S(i, j) + S(j, i));
        S(i, j) = v;
        S(j, i) = v;
      }
    }
  }
}

template <typename Mat>
void MirrorLower(Mat& S) {
  for (Eigen::Index j = 1; j < S.cols(); ++j) S.col(j).head(j) = S.row(j).head(j).transpose();
}

// The step's matrices: referenced for dynamic sizes, copied into the small types (once per
// distinct step: a time-invariant model copies them once per run).
template <typename Mat>
struct StepMatrices {
  Mat A, C, Q, R, S;
  void Set(const ModelStep& s) {
    A = s.A;
    C = s.C;
    Q = s.Q;
    R = s.R;
    S = s.S;
  }
  const Mat& a() const { return A; }
  const Mat& c() const { return C; }
  const Mat& q() const { return Q; }
  const Mat& r() const { return R; }
  const Mat& cross() const { return S; }
};
template <>
struct StepMatrices<Eigen::MatrixXd> {
  const ModelStep* s = nullptr;
  void Set(const ModelStep& step) { s = &step; }
  const Eigen::MatrixXd& a() const { return s->A; }
  const Eigen::MatrixXd& c() const { return s->C; }
  const Eigen::MatrixXd& q() const { return s->Q; }
  const Eigen::MatrixXd& r() const { return s->R; }
  const Eigen::MatrixXd& cross() const { return s->S; }
};

// Storage reused from step to step by the in-place predict and update.
template <typename Mat, typename Vec>
struct StepWorkspace {
  Mat B;                               // n x n: A P, or A L for the symmetric product
  Vec xt;                              // n: A x
  Mat U, K, Z;                         // n x m_obs: P C^T, the gain, Joseph's second factor
  Mat S;                               // m_obs x m_obs innovation covariance
  Mat Co, Ro;                          // observed rows of C, R when some entries are missing
  Mat So, CS;                          // cross-covariance: observed columns of S, C S
  Vec nu, w;                           // innovation, L^{-1} nu
  Eigen::LLT<Mat> llt;                 // of S
  std::vector<Eigen::Index> observed;  // indices of the observed entries of y
  double log_likelihood = 0.0;
};

// x <- A x, P <- A P A^T + Q, in place (P symmetric on entry and exit).
template <typename Mat, typename Vec>
void PredictInPlace(const Mat& A, const Mat& Q, const KalmanFilterOptions& options, Vec& x, Mat& P,
                    StepWorkspace<Mat, Vec>& w) {
  Prod<Mat, false>(w.xt, A, x, Acc::kSet);
  x = w.xt;
  if constexpr (std::is_same_v<Mat, Eigen::MatrixXd>) {
    const Eigen::Index n = A.rows();
    if (n >= kSymmetricProductMin) {
      // A P A^T + Q in 3 n^3 flops instead of two GEMMs' 4 n^3: with P = L + L^T (L the lower
      // triangle of P with its diagonal halved) and B = A L (DTRMM, n^3), A P A^T = B A^T + A B^T
      // (DSYR2K, 2 n^3, the lower triangle only). P itself holds L and then the result, so the
      // step needs P and B only: 2 n^2 doubles.
      const int ni = static_cast<int>(n);
      const double one = 1.0;
      w.B = A;
      P.diagonal() *= 0.5;
      dtrmm_("R", "L", "N", "N", &ni, &ni, &one, P.data(), &ni, w.B.data(), &ni);
      P = Q;
      dsyr2k_("L", "N", &ni, &ni, &one, w.B.data(), &ni, A.data(), &ni, &one, P.data(), &ni);
      MirrorLower(P);
      return;  // exactly symmetric already
    }
  }
  Prod<Mat, false>(w.B, A, P, Acc::kSet);
  P = Q;
  Prod<Mat, true>(P, w.B, A, Acc::kAdd);
  if (options.symmetrize) SymmetrizeInPlace(P);
}

// K = U S^{-1} from the Cholesky factor S = L L^T.
template <typename Mat>
void RightSolve(const Eigen::LLT<Mat>& llt, const Mat& U, Mat& K) {
  if constexpr (std::is_same_v<Mat, Eigen::MatrixXd>) {
    K = llt.solve(U.transpose()).transpose();
  } else {  // tiny m: substitution row by row (a DTRSM call costs more than the flops)
    const Mat& L = llt.matrixLLT();
    const Eigen::Index n = U.rows(), m = U.cols();
    K.resize(n, m);
    for (Eigen::Index i = 0; i < n; ++i) {
      for (Eigen::Index j = 0; j < m; ++j) {  // L t = u
        double t = U(i, j);
        for (Eigen::Index l = 0; l < j; ++l) t -= L(j, l) * K(i, l);
        K(i, j) = t / L(j, j);
      }
      for (Eigen::Index j = m - 1; j >= 0; --j) {  // L^T k = t
        double t = K(i, j);
        for (Eigen::Index l = j + 1; l < m; ++l) t -= L(l, j) * K(i, l);
        K(i, j) = t / L(j, j);
      }
    }
  }
}

// The measurement update in place: x <- x + K nu, P <- P_{k|k}; w holds the observed indices, nu,
// S (factored), K and the log-likelihood term. With U = P C^T and K = U S^{-1}:
//   Joseph:   M = P - K U^T  (= (I - K C) P),   P+ = M - (M C^T) K^T + K R K^T
// which is (I - K C) P (I - K C)^T + K R K^T evaluated without forming I - K C: O(n^2 m).
// Returns false (nothing changed) when no entry of y is observed.
// With a cross-covariance S = E[w_k v_k^T] (not empty; the noise producing x_k and the measurement of x_k),
// the correlated update (FilterPy's update_correlated): U = P C^T + S, S_k = C P C^T + C S + S^T C^T + R,
// K = U S_k^{-1}; the standard form P - K U^T holds as it is, the Joseph form is evaluated as
// P - K Z^T - Z K^T with Z = U - K S_k / 2, which equals
// (I - K C) P (I - K C)^T + K R K^T - (I - K C) S K^T - K S^T (I - K C)^T for any K.
template <typename Mat, typename Vec, typename YType>
bool UpdateInPlace(const Mat& C, const Mat& R, const Mat& S, const YType& y, const KalmanFilterOptions& options, Vec& x,
                   Mat& P, StepWorkspace<Mat, Vec>& w) {
  const Eigen::Index n = P.rows(), m = C.rows();
  w.observed.clear();
  for (Eigen::Index i = 0; i < m; ++i) {
    if (std::isinf(y(i))) throw Error("y: expected finite entries or NaN (missing), got inf at " + std::to_string(i));
    if (!std::isnan(y(i))) w.observed.push_back(i);
  }
  const Eigen::Index mo = static_cast<Eigen::Index>(w.observed.size());
  w.log_likelihood = 0.0;
  if (mo == 0) {
    w.nu.resize(0);
    w.S.resize(0, 0);
    w.K.resize(n, 0);
    return false;
  }
  const Mat* Cp = &C;
  const Mat* Rp = &R;
  const bool cross = S.size() > 0;
  const Mat* Sp = &S;
  w.nu.resize(mo);
  if (mo == m) {
    w.nu = y;
  } else {
    if (cross) {
      w.So.resize(n, mo);
      for (Eigen::Index i = 0; i < mo; ++i) w.So.col(i) = S.col(w.observed[i]);
      Sp = &w.So;
    }
    w.Co.resize(mo, n);
    w.Ro.resize(mo, mo);
    for (Eigen::Index i = 0; i < mo; ++i) {
      w.nu(i) = y(w.observed[i]);
      w.Co.row(i) = C.row(w.observed[i]);
      for (Eigen::Index j = 0; j < mo; ++j) w.Ro(i, j) = R(w.observed[i], w.observed[j]);
    }
    Cp = &w.Co;
    Rp = &w.Ro;
  }
  Prod<Mat, false>(w.nu, *Cp, x, Acc::kSub);
  Prod<Mat, true>(w.U, P, *Cp, Acc::kSet);  // n x mo
  if (cross) w.U += *Sp;                    // P C^T + S
  w.S = *Rp;
  Prod<Mat, false>(w.S, *Cp, w.U, Acc::kAdd);  // R + C P C^T (+ C S)
  if (cross) {
    Prod<Mat, false>(w.CS, *Cp, *Sp, Acc::kSet);
    w.S += w.CS.transpose();  // + S^T C^T
  }
  SymmetrizeInPlace(w.S);
  w.llt.compute(w.S);
  if (w.llt.info() != Eigen::Success) {
    throw NumericalError("innovation covariance S = C P C^T + R: not positive definite (Cholesky failed)");
  }
  // A Cholesky that succeeds by a rounding error (a pivot at the level of m eps max S_ii) has factored a
  // matrix that is singular to working precision: whether it succeeds then depends on the order of the
  // operations, and the gain it gives is noise. Refused alike on every machine.
  {
    const double pivot = w.llt.matrixLLT().diagonal().minCoeff();
    const double scale = w.S.diagonal().maxCoeff();
    if (pivot * pivot <= static_cast<double>(mo) * std::numeric_limits<double>::epsilon() * scale) {
      char text[64];
      std::snprintf(text, sizeof text, "%.3g", pivot * pivot);
      throw NumericalError(std::string("innovation covariance S = C P C^T + R: singular to working precision "
                                       "(smallest Cholesky pivot^2 ") +
                           text + " <= m eps max S_ii)");
    }
  }
  RightSolve(w.llt, w.U, w.K);
  Prod<Mat, false>(x, w.K, w.nu, Acc::kAdd);
  bool done = false;
  if constexpr (std::is_same_v<Mat, Eigen::MatrixXd>) {
    if (options.update_form == CovarianceUpdateForm::kJoseph && n >= kSymmetricProductMin) {
      // Joseph = P - K U^T - U K^T + K S K^T (an identity for any K) = P - K Z^T - Z K^T with
      // Z = U - K S / 2: one DSYR2K, 2 n^2 m flops instead of 8 n^2 m.
      const int ni = static_cast<int>(n), mi = static_cast<int>(mo);
      w.Z = w.U;
      w.Z.noalias() -= 0.5 * w.K * w.S;
      const double minus_one = -1.0, one = 1.0;
      dsyr2k_("L", "N", &ni, &mi, &minus_one, w.K.data(), &ni, w.Z.data(), &ni, &one, P.data(), &ni);
      MirrorLower(P);
      done = true;
    }
  }
  if (!done && cross && options.update_form == CovarianceUpdateForm::kJoseph) {
    Prod<Mat, false>(w.Z, w.K, w.S, Acc::kSet);  // Z = U - K S_k / 2
    w.Z *= -0.5;
    w.Z += w.U;
    Prod<Mat, true>(P, w.K, w.Z, Acc::kSub);
    Prod<Mat, true>(P, w.Z, w.K, Acc::kSub);
    if (options.symmetrize) SymmetrizeInPlace(P);
    done = true;
  }
  if (!done) {
    Prod<Mat, true>(P, w.K, w.U, Acc::kSub);
    if (options.update_form == CovarianceUpdateForm::kJoseph) {
      Prod<Mat, true>(w.Z, P, *Cp, Acc::kSet);  // M C^T
      Prod<Mat, true>(P, w.Z, w.K, Acc::kSub);
      Prod<Mat, false>(w.U, w.K, *Rp, Acc::kSet);  // K R (U is no longer needed)
      Prod<Mat, true>(P, w.U, w.K, Acc::kAdd);
    }
    if (options.symmetrize) SymmetrizeInPlace(P);
  }
  w.w = w.nu;
  w.llt.matrixL().solveInPlace(w.w);
  const double log_det = 2.0 * w.llt.matrixLLT().diagonal().array().log().sum();
  w.log_likelihood = -0.5 * (static_cast<double>(mo) * kLog2Pi + log_det + w.w.squaredNorm());
  return true;
}

/// The conventional form over one run or one Predict/Update call: x and P of the current step in
/// Mat/Vec storage, the step's matrices and the workspace (the form interface: filter_form.cpp).
template <typename Mat, typename Vec>
class ConventionalForm {
 public:
  using Matrix = Mat;
  /// RunFilter's steady-state fast path (FilterRunOptions::steady_state_tolerance) is this form's.
  static constexpr bool kSteadyState = true;

  ConventionalForm(const KalmanFilterOptions& options, Eigen::Index /*n*/) : options_(options) {}
  /// The prefix of a step's NumericalError messages (none: the conventional form is the default).
  std::string context() const { return ""; }
  void Start(const Eigen::VectorXd& x, const Eigen::MatrixXd& P) {
    x_ = x;
    P_ = P;
  }
  void SetStep(const ModelStep& s) { sm_.Set(s); }
  void Predict() { PredictInPlace(sm_.a(), sm_.q(), options_, x_, P_, w_); }
  /// false (nothing changed) when no entry of y is observed.
  template <typename YType>
  bool Update(const YType& y) {
    return UpdateInPlace(sm_.c(), sm_.r(), sm_.cross(), y, options_, x_, P_, w_);
  }

  /// x <- x + v (a known input's G_k g_k after Predict).
  void ShiftMean(const Eigen::VectorXd& v) { x_ += v; }
  const Vec& x() const { return x_; }
  const Mat& P() const { return P_; }
  const Vec& innovation() const { return w_.nu; }
  const Mat& innovation_cov() const { return w_.S; }
  const Mat& gain() const { return w_.K; }
  const std::vector<Eigen::Index>& observed() const { return w_.observed; }
  double log_likelihood() const { return w_.log_likelihood; }

  /// Steady state: keeps the gain and the S_k factor of the last (fully observed) update.
  void Freeze() {
    K_ss_ = w_.K;
    S_ss_ = w_.llt;
    log_det_ss_ = 2.0 * S_ss_.matrixLLT().diagonal().array().log().sum();
  }
  /// A step on the frozen gain (y fully observed): the mean only, P stays the frozen P_{k|k};
  /// shift = G_k g_k (empty: none) is added to the prediction.
  template <typename YType>
  void FrozenStep(const YType& y, const Eigen::VectorXd& shift) {
    Prod<Mat, false>(x_pred_, sm_.a(), x_, Acc::kSet);
    if (shift.size() > 0) x_pred_ += shift;
    nu_ss_ = y;
    Prod<Mat, false>(nu_ss_, sm_.c(), x_pred_, Acc::kSub);
    x_ = x_pred_;
    Prod<Mat, false>(x_, K_ss_, nu_ss_, Acc::kAdd);
    v_ss_ = nu_ss_;
    S_ss_.matrixL().solveInPlace(v_ss_);
    log_likelihood_ss_ = -0.5 * (static_cast<double>(nu_ss_.size()) * kLog2Pi + log_det_ss_ + v_ss_.squaredNorm());
  }
  const Vec& frozen_prediction() const { return x_pred_; }
  const Vec& frozen_innovation() const { return nu_ss_; }
  double frozen_log_likelihood() const { return log_likelihood_ss_; }

 private:
  KalmanFilterOptions options_;
  Vec x_;
  Mat P_;
  StepMatrices<Mat> sm_;
  StepWorkspace<Mat, Vec> w_;
  Mat K_ss_;  // steady state: the frozen gain and S_k factor, the step's prediction and innovation
  Eigen::LLT<Mat> S_ss_;
  double log_det_ss_ = 0.0;
  Vec x_pred_, nu_ss_, v_ss_;
  double log_likelihood_ss_ = 0.0;
};

}  // namespace kfx::detail::conventional
