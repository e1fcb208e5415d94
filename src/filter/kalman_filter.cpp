#include "kfx/kalman_filter.hpp"

#include <cmath>
#include <limits>
#include <type_traits>

#include "filter/filter_forms.hpp"
#include "filter/filter_health_internal.hpp"
#include "kfx/error.hpp"
#include "kfx/validation.hpp"

namespace kfx {

namespace {

constexpr double kLog2Pi = 1.8378770664093454835606594728112;

void CheckEstimate(const Estimate& e, Eigen::Index n, const char* what) {
  RequireVector(std::string(what) + ".x", e.x, n);
  RequireShape(std::string(what) + ".P", e.P, n, n);
}

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

bool IsSmall(Eigen::Index n, Eigen::Index m) { return n <= kSmallMax && m <= kSmallMax; }

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
  Mat A, C, Q, R;
  void Set(const ModelStep& s) {
    A = s.A;
    C = s.C;
    Q = s.Q;
    R = s.R;
  }
  const Mat& a() const { return A; }
  const Mat& c() const { return C; }
  const Mat& q() const { return Q; }
  const Mat& r() const { return R; }
};
template <>
struct StepMatrices<Eigen::MatrixXd> {
  const ModelStep* s = nullptr;
  void Set(const ModelStep& step) { s = &step; }
  const Eigen::MatrixXd& a() const { return s->A; }
  const Eigen::MatrixXd& c() const { return s->C; }
  const Eigen::MatrixXd& q() const { return s->Q; }
  const Eigen::MatrixXd& r() const { return s->R; }
};

// Storage reused from step to step by the in-place predict and update.
template <typename Mat, typename Vec>
struct StepWorkspace {
  Mat B;                               // n x n: A P, or A L for the symmetric product
  Vec xt;                              // n: A x
  Mat U, K, Z;                         // n x m_obs: P C^T, the gain, Joseph's second factor
  Mat S;                               // m_obs x m_obs innovation covariance
  Mat Co, Ro;                          // observed rows of C, R when some entries are missing
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
template <typename Mat, typename Vec, typename YType>
bool UpdateInPlace(const Mat& C, const Mat& R, const YType& y, const KalmanFilterOptions& options, Vec& x, Mat& P,
                   StepWorkspace<Mat, Vec>& w) {
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
  w.nu.resize(mo);
  if (mo == m) {
    w.nu = y;
  } else {
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
  w.S = *Rp;
  Prod<Mat, false>(w.S, *Cp, w.U, Acc::kAdd);
  SymmetrizeInPlace(w.S);
  w.llt.compute(w.S);
  if (w.llt.info() != Eigen::Success) {
    throw NumericalError("innovation covariance S = C P C^T + R: not positive definite (Cholesky failed)");
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

template <typename Mat, typename Vec>
Estimate PredictImpl(const Estimate& e, const ModelStep& s, const KalmanFilterOptions& options) {
  StepMatrices<Mat> sm;
  sm.Set(s);
  StepWorkspace<Mat, Vec> w;
  Vec x = e.x;
  Mat P = e.P;
  PredictInPlace(sm.a(), sm.q(), options, x, P, w);
  return Estimate{x, P};
}

template <typename Mat, typename Vec>
UpdateResult UpdateImpl(const Estimate& prior, const ModelStep& s, const Eigen::Ref<const Eigen::VectorXd>& y,
                        const KalmanFilterOptions& options) {
  StepMatrices<Mat> sm;
  sm.Set(s);
  StepWorkspace<Mat, Vec> w;
  Vec x = prior.x;
  Mat P = prior.P;
  UpdateResult r;
  if (!UpdateInPlace(sm.c(), sm.r(), y, options, x, P, w)) {
    r.estimate = prior;
    r.gain.resize(prior.x.size(), 0);
    return r;
  }
  r.estimate.x = x;
  r.estimate.P = P;
  r.innovation = w.nu;
  r.innovation_cov = w.S;
  r.gain = w.K;
  r.observed = w.observed;
  r.log_likelihood = w.log_likelihood;
  return r;
}

// The conventional-form filter over a whole sequence, in place: P (and, with the steady-state fast
// path, P_{k-1|k-1} for the convergence test) plus the step workspace are all the covariance
// storage a step needs.
template <typename Mat, typename Vec>
void RunConventional(const Model& model, const TimeSeries& y, const FilterRunOptions& options, int T, FilterRun& run) {
  const Eigen::Index n = model.state_dim(), m = model.meas_dim();
  detail::HealthMonitor monitor(options.monitor_health);
  Vec x = model.m0();
  Mat P = model.P0();
  StepWorkspace<Mat, Vec> w;
  w.observed.reserve(static_cast<size_t>(m));
  StepMatrices<Mat> sm;
  StepPtr current;  // keeps the step that sm refers to alive
  // Steady-state fast path (FilterRunOptions::steady_state_tolerance): the frozen gain, S_k factor
  // and covariances; P keeps the frozen P_{k|k} so that a missing measurement can resume the full
  // recursion from it.
  const double tol = options.steady_state_tolerance;
  if (!(tol >= 0.0 && tol <= 1e-2)) {
    throw Error("options.steady_state_tolerance: expected a value in [0, 1e-2], got " + std::to_string(tol));
  }
  const bool fast = tol > 0.0 && model.time_invariant();
  bool frozen = false;
  Mat K_ss, P_pred_ss, P_prev;
  Eigen::LLT<Mat> S_ss;
  Vec x_pred(n), nu(m), v(m);
  double log_det_ss = 0.0;
  for (int k = 1; k <= T; ++k) {
    StepPtr s = model.step(k);
    if (s.get() != current.get()) {
      sm.Set(*s);
      current = std::move(s);
    }
    const auto yk = y.row(k - 1).transpose();
    if (frozen && yk.allFinite()) {
      Prod<Mat, false>(x_pred, sm.a(), x, Acc::kSet);
      nu = yk;
      Prod<Mat, false>(nu, sm.c(), x_pred, Acc::kSub);
      x = x_pred;
      Prod<Mat, false>(x, K_ss, nu, Acc::kAdd);
      v = nu;
      S_ss.matrixL().solveInPlace(v);
      run.x_pred.row(k) = x_pred.transpose();
      run.P_pred_diag.row(k) = run.P_pred_diag.row(k - 1);
      run.innovations.row(k - 1) = nu.transpose();
      run.num_observed[static_cast<size_t>(k - 1)] = static_cast<int>(m);
      run.log_likelihood_terms(k - 1) = -0.5 * (static_cast<double>(m) * kLog2Pi + log_det_ss + v.squaredNorm());
      run.x_filt.row(k) = x.transpose();
      run.P_filt_diag.row(k) = run.P_filt_diag.row(k - 1);
      if (options.store_covariances) {
        run.P_pred.emplace_back(P_pred_ss);
        run.P_filt.emplace_back(P);
      }
      ++run.steady_state_steps;
      if (options.progress) options.progress(k, T);
      continue;
    }
    frozen = false;
    if (fast) P_prev = P;
    PredictInPlace(sm.a(), sm.q(), options.filter, x, P, w);
    run.x_pred.row(k) = x.transpose();
    run.P_pred_diag.row(k) = P.diagonal().transpose();
    if (options.store_covariances) run.P_pred.emplace_back(P);
    if (fast && options.store_covariances) P_pred_ss = P;  // only the stored frozen P_{k|k-1} needs it
    try {
      UpdateInPlace(sm.c(), sm.r(), yk, options.filter, x, P, w);
    } catch (const Error& err) {
      std::string what = err.what();
      if (what.rfind("y: ", 0) == 0) what = what.substr(3);
      throw Error("y (row " + std::to_string(k - 1) + "): " + what);
    } catch (const NumericalError& err) {
      throw NumericalError("step " + std::to_string(k) + ": " + err.what());
    }
    const Eigen::Index mo = static_cast<Eigen::Index>(w.observed.size());
    for (Eigen::Index i = 0; i < mo; ++i) run.innovations(k - 1, w.observed[i]) = w.nu(i);
    run.num_observed[static_cast<size_t>(k - 1)] = static_cast<int>(mo);
    run.log_likelihood_terms(k - 1) = w.log_likelihood;
    if (!(x.allFinite() && P.allFinite() && std::isfinite(w.log_likelihood))) {
      detail::RequireFiniteStep(k, x, P, w.log_likelihood);  // throws, naming what is not finite
    }
    if (options.monitor_health) monitor.Observe(k, P, w.nu, w.S);
    if (fast && mo == m && (P - P_prev).norm() <= tol * P.norm()) {
      frozen = true;
      K_ss = w.K;
      S_ss = w.llt;
      log_det_ss = 2.0 * S_ss.matrixLLT().diagonal().array().log().sum();
    }
    run.x_filt.row(k) = x.transpose();
    run.P_filt_diag.row(k) = P.diagonal().transpose();
    if (options.store_covariances) run.P_filt.emplace_back(P);
    if (options.progress) options.progress(k, T);
  }
  run.health = monitor.Finish();
}

}  // namespace

const char* ToString(CovarianceUpdateForm form) {
  switch (form) {
    case CovarianceUpdateForm::kJoseph:
      return "joseph";
    case CovarianceUpdateForm::kStandard:
      return "standard";
  }
  return "unknown";
}

const char* ToString(FilterForm form) {
  switch (form) {
    case FilterForm::kConventional:
      return "conventional";
    case FilterForm::kSquareRoot:
      return "sqrt";
    case FilterForm::kUD:
      return "ud";
    case FilterForm::kInformation:
      return "information";
  }
  return "unknown";
}

bool KalmanFilterOptions::IsValid(std::string* error) const {
  if (update_form != CovarianceUpdateForm::kJoseph && update_form != CovarianceUpdateForm::kStandard) {
    if (error) *error = "update_form: expected kJoseph or kStandard";
    return false;
  }
  if (form != FilterForm::kConventional && form != FilterForm::kSquareRoot && form != FilterForm::kUD &&
      form != FilterForm::kInformation) {
    if (error) *error = "form: expected kConventional, kSquareRoot, kUD or kInformation";
    return false;
  }
  return true;
}

Estimate Predict(const Estimate& e, const ModelStep& s, const KalmanFilterOptions& options) {
  if (options.form != FilterForm::kConventional) return detail::FactoredPredict(e, s, options);
  const Eigen::Index n = s.A.rows();
  CheckEstimate(e, n, "estimate");
  if (IsSmall(n, s.C.rows())) return PredictImpl<SmallMat, SmallVec>(e, s, options);
  return PredictImpl<Eigen::MatrixXd, Eigen::VectorXd>(e, s, options);
}

UpdateResult Update(const Estimate& prior, const ModelStep& s, const Eigen::Ref<const Eigen::VectorXd>& y,
                    const KalmanFilterOptions& options) {
  if (options.form != FilterForm::kConventional) return detail::FactoredUpdate(prior, s, y, options);
  const Eigen::Index n = s.A.rows(), m = s.C.rows();
  CheckEstimate(prior, n, "prior");
  if (y.size() != m) {
    throw Error("y: expected a measurement of length " + std::to_string(m) + ", got length " +
                std::to_string(y.size()));
  }
  if (IsSmall(n, m)) return UpdateImpl<SmallMat, SmallVec>(prior, s, y, options);
  return UpdateImpl<Eigen::MatrixXd, Eigen::VectorXd>(prior, s, y, options);
}

KalmanFilter::KalmanFilter(Model model, KalmanFilterOptions options) : model_(std::move(model)), options_(options) {
  std::string why;
  if (!options_.IsValid(&why)) throw Error("options: " + why);
  Reset();
}

void KalmanFilter::Reset() {
  estimate_ = Estimate{model_.m0(), model_.P0()};
  k_ = 0;
  predicted_ = false;
}

void KalmanFilter::Predict() {
  estimate_ = kfx::Predict(estimate_, *model_.step(k_ + 1), options_);
  ++k_;
  predicted_ = true;
}

UpdateResult KalmanFilter::Update(const Eigen::Ref<const Eigen::VectorXd>& y) {
  if (!predicted_) throw Error("Update: expected a Predict() before each Update() (k = " + std::to_string(k_) + ")");
  UpdateResult r = kfx::Update(estimate_, *model_.step(k_), y, options_);
  estimate_ = r.estimate;
  predicted_ = false;
  return r;
}

UpdateResult KalmanFilter::Step(const Eigen::Ref<const Eigen::VectorXd>& y) {
  Predict();
  return Update(y);
}

FilterRun RunFilter(const Model& model, const TimeSeries& y, const FilterRunOptions& options) {
  std::string why;
  if (!options.filter.IsValid(&why)) throw Error("options.filter: " + why);
  if (options.filter.form != FilterForm::kConventional) return detail::FactoredRunFilter(model, y, options);
  const Eigen::Index n = model.state_dim(), m = model.meas_dim();
  if (y.cols() != m) {
    throw Error("y: expected " + std::to_string(m) + (m == 1 ? " column" : " columns") +
                " (the model's measurement dimension), got " + ShapeString(y.rows(), y.cols()));
  }
  const int T = model.ResolveSteps(static_cast<int>(y.rows()), "y (rows)");
  FilterRun run;
  run.x_filt.resize(T + 1, n);
  run.x_pred.resize(T + 1, n);
  run.P_filt_diag.resize(T + 1, n);
  run.P_pred_diag.resize(T + 1, n);
  run.innovations = TimeSeries::Constant(T, m, std::numeric_limits<double>::quiet_NaN());
  run.log_likelihood_terms = Eigen::VectorXd::Zero(T);
  run.num_observed.assign(static_cast<size_t>(T), 0);
  run.x_filt.row(0) = model.m0().transpose();
  run.x_pred.row(0) = model.m0().transpose();
  run.P_filt_diag.row(0) = model.P0().diagonal().transpose();
  run.P_pred_diag.row(0) = model.P0().diagonal().transpose();
  if (options.store_covariances) {
    run.P_filt.reserve(static_cast<size_t>(T) + 1);
    run.P_pred.reserve(static_cast<size_t>(T) + 1);
    run.P_filt.push_back(model.P0());
    run.P_pred.push_back(model.P0());
  }
  if (IsSmall(n, m)) {
    RunConventional<SmallMat, SmallVec>(model, y, options, T, run);
  } else {
    RunConventional<Eigen::MatrixXd, Eigen::VectorXd>(model, y, options, T, run);
  }
  run.log_likelihood = run.log_likelihood_terms.sum();
  return run;
}

SmootherRun RtsSmooth(const Model& model, const FilterRun& run) {
  const Eigen::Index n = model.state_dim();
  const int T = static_cast<int>(run.x_filt.rows()) - 1;
  if (T < 0 || run.x_filt.cols() != n)
    throw Error("run: expected a filter run of this model (n = " + std::to_string(n) + ")");
  if (static_cast<int>(run.P_filt.size()) != T + 1 || static_cast<int>(run.P_pred.size()) != T + 1) {
    throw Error("run: expected stored covariances (FilterRunOptions::store_covariances = true)");
  }
  SmootherRun sm;
  sm.x.resize(T + 1, n);
  sm.P_diag.resize(T + 1, n);
  sm.P.resize(static_cast<size_t>(T) + 1);
  Eigen::VectorXd xs = run.x_filt.row(T).transpose();
  Eigen::MatrixXd Ps = run.P_filt[static_cast<size_t>(T)];
  sm.x.row(T) = xs.transpose();
  sm.P_diag.row(T) = Ps.diagonal().transpose();
  sm.P[static_cast<size_t>(T)] = Ps;
  for (int k = T - 1; k >= 0; --k) {
    const size_t kk = static_cast<size_t>(k);
    const StepPtr s = model.step(k + 1);
    const Eigen::MatrixXd& Pp = run.P_pred[kk + 1];
    const Eigen::MatrixXd APf = s->A * run.P_filt[kk];  // A_{k+1} P_{k|k}  (= (P_{k|k} A^T)^T)
    Eigen::MatrixXd Gt;                                 // G_k^T = P_{k+1|k}^{-1} A_{k+1} P_{k|k}
    Eigen::LLT<Eigen::MatrixXd> llt(Pp);
    bool solved = false;
    if (llt.info() == Eigen::Success) {
      const double dmin = llt.matrixLLT().diagonal().minCoeff();
      const double dmax = llt.matrixLLT().diagonal().maxCoeff();
      if (dmin > 1e-8 * dmax) {
        Gt = llt.solve(APf);
        solved = true;
      }
    }
    if (!solved) Gt = Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd>(Pp).solve(APf);
    const Eigen::MatrixXd G = Gt.transpose();
    xs = run.x_filt.row(k).transpose() + G * (xs - run.x_pred.row(k + 1).transpose());
    Eigen::MatrixXd D = Ps - Pp;
    Ps = run.P_filt[kk];
    Ps.noalias() += G * D * Gt;
    Symmetrize(Ps);
    sm.x.row(k) = xs.transpose();
    sm.P_diag.row(k) = Ps.diagonal().transpose();
    sm.P[kk] = Ps;
  }
  return sm;
}

KalmanSchedule ComputeKalmanSchedule(const Model& model, const KalmanScheduleOptions& schedule_options) {
  const KalmanFilterOptions& options = schedule_options.filter;
  std::string why;
  if (!options.IsValid(&why)) throw Error("options.filter: " + why);
  if (options.form != FilterForm::kConventional) return detail::FactoredKalmanSchedule(model, schedule_options);
  const int T = model.ResolveSteps(schedule_options.steps);
  KalmanSchedule sch;
  sch.filter_gain.resize(static_cast<size_t>(T) + 1);
  sch.P_pred.reserve(static_cast<size_t>(T) + 1);
  sch.P_filt.reserve(static_cast<size_t>(T) + 1);
  sch.P_pred.push_back(model.P0());
  sch.P_filt.push_back(model.P0());
  // The covariance recursion of RunFilter (dynamic sizes), with a zero measurement for the mean.
  Eigen::VectorXd x = Eigen::VectorXd::Zero(model.state_dim());
  Eigen::MatrixXd P = model.P0();
  const Eigen::VectorXd y0 = Eigen::VectorXd::Zero(model.meas_dim());
  StepWorkspace<Eigen::MatrixXd, Eigen::VectorXd> w;
  for (int k = 1; k <= T; ++k) {
    const StepPtr s = model.step(k);
    PredictInPlace(s->A, s->Q, options, x, P, w);
    sch.P_pred.push_back(P);
    UpdateInPlace(s->C, s->R, y0, options, x, P, w);
    sch.P_filt.push_back(P);
    sch.filter_gain[static_cast<size_t>(k)] = w.K;
    if (schedule_options.progress) schedule_options.progress(k, T);
  }
  return sch;
}

LinearFilter KalmanAsLinearFilter(const Model& model, const KalmanSchedule& schedule) {
  const int T = static_cast<int>(schedule.filter_gain.size()) - 1;
  if (T < 1) throw Error("schedule: expected at least one step");
  std::vector<LinearFilterStep> steps;
  steps.reserve(static_cast<size_t>(T));
  for (int k = 1; k <= T; ++k) {
    const StepPtr s = model.step(k);
    const Eigen::MatrixXd& K = schedule.filter_gain[static_cast<size_t>(k)];
    LinearFilterStep f;
    f.Phi = s->A;
    f.Phi.noalias() -= K * (s->C * s->A);
    f.K = K;
    steps.push_back(std::move(f));
  }
  return LinearFilter(std::move(steps), model.m0());
}

LinearFilter ConstantGainAsLinearFilter(const ModelStep& design, const Eigen::Ref<const Eigen::MatrixXd>& filter_gain,
                                        const Eigen::Ref<const Eigen::VectorXd>& z0) {
  RequireShape("filter_gain", filter_gain, design.state_dim(), design.meas_dim());
  LinearFilterStep f;
  f.Phi = design.A;
  f.Phi.noalias() -= filter_gain * (design.C * design.A);
  f.K = filter_gain;
  return LinearFilter(std::move(f), z0);
}

}  // namespace kfx
