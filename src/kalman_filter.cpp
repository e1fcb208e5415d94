#include "kfx/kalman_filter.hpp"

#include <cmath>

#include "kfx/error.hpp"
#include "kfx/validation.hpp"
#include "robust_filter.hpp"

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

void MirrorLower(Eigen::MatrixXd* S) {
  for (Eigen::Index j = 1; j < S->cols(); ++j) S->col(j).head(j) = S->row(j).head(j).transpose();
}

// *out = Q + A P A^T for symmetric P in 3 n^3 flops instead of two GEMMs' 4 n^3: with P = L + L^T
// (L the lower triangle of P with its diagonal halved) and B = A L (DTRMM, n^3),
// A P A^T = B A^T + A B^T (DSYR2K, 2 n^3, the lower triangle only).
void AddCongruence(const Eigen::MatrixXd& A, const Eigen::MatrixXd& P, const Eigen::MatrixXd& Q, Eigen::MatrixXd* out) {
  const int n = static_cast<int>(A.rows());
  Eigen::MatrixXd L = P;
  L.diagonal() *= 0.5;
  Eigen::MatrixXd B = A;
  const double one = 1.0;
  dtrmm_("R", "L", "N", "N", &n, &n, &one, L.data(), &n, B.data(), &n);
  *out = Q;
  dsyr2k_("L", "N", &n, &n, &one, B.data(), &n, A.data(), &n, &one, out->data(), &n);
  MirrorLower(out);
}

// The covariance part of the measurement update, shared by Update (online) and
// ComputeKalmanSchedule (offline). With U = P C^T and K = U S^{-1}:
//   Joseph:   M = P - K U^T  (= (I - K C) P),   P+ = M - (M C^T) K^T + K R K^T
// which is (I - K C) P (I - K C)^T + K R K^T evaluated without forming I - K C: O(n^2 m).
struct CovarianceUpdateResult {
  Eigen::MatrixXd P;
  Eigen::MatrixXd K;
  Eigen::MatrixXd S;
  Eigen::LLT<Eigen::MatrixXd> S_llt;
};

template <typename CType, typename RType>
void CovarianceUpdate(const Eigen::MatrixXd& P, const CType& C, const RType& R, const KalmanFilterOptions& options,
                      CovarianceUpdateResult* out) {
  const Eigen::MatrixXd U = P * C.transpose();  // n x m
  out->S = R;
  out->S.noalias() += C * U;
  Symmetrize(out->S);
  out->S_llt.compute(out->S);
  if (out->S_llt.info() != Eigen::Success) {
    throw NumericalError("innovation covariance S = C P C^T + R: not positive definite (Cholesky failed)");
  }
  out->K = out->S_llt.solve(U.transpose()).transpose();  // n x m
  if (options.update_form == CovarianceUpdateForm::kJoseph && P.rows() >= kSymmetricProductMin) {
    // Joseph = P - K U^T - U K^T + K S K^T (an identity for any K) = P - K Z^T - Z K^T with
    // Z = U - K S / 2: one DSYR2K, 2 n^2 m flops instead of 8 n^2 m.
    const int n = static_cast<int>(P.rows()), m = static_cast<int>(U.cols());
    Eigen::MatrixXd Z = U;
    Z.noalias() -= 0.5 * out->K * out->S;
    out->P = P;
    const double minus_one = -1.0, one = 1.0;
    dsyr2k_("L", "N", &n, &m, &minus_one, out->K.data(), &n, Z.data(), &n, &one, out->P.data(), &n);
    MirrorLower(&out->P);
    return;
  }
  out->P = P;
  out->P.noalias() -= out->K * U.transpose();
  if (options.update_form == CovarianceUpdateForm::kJoseph) {
    const Eigen::MatrixXd MCt = out->P * C.transpose();
    out->P.noalias() -= MCt * out->K.transpose();
    const Eigen::MatrixXd KR = out->K * R;
    out->P.noalias() += KR * out->K.transpose();
  }
  if (options.symmetrize) Symmetrize(out->P);
}

}  // namespace

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
  Estimate out;
  out.x.noalias() = s.A * e.x;
  if (n >= kSymmetricProductMin) {
    AddCongruence(s.A, e.P, s.Q, &out.P);
    return out;  // exactly symmetric already
  }
  Eigen::MatrixXd AP(n, n);
  AP.noalias() = s.A * e.P;
  out.P = s.Q;
  out.P.noalias() += AP * s.A.transpose();
  if (options.symmetrize) Symmetrize(out.P);
  return out;
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
  UpdateResult r;
  for (Eigen::Index i = 0; i < m; ++i) {
    if (std::isinf(y(i))) throw Error("y: expected finite entries or NaN (missing), got inf at " + std::to_string(i));
    if (!std::isnan(y(i))) r.observed.push_back(i);
  }
  if (r.observed.empty()) {
    r.estimate = prior;
    r.gain.resize(n, 0);
    return r;
  }
  CovarianceUpdateResult cu;
  const bool all = static_cast<Eigen::Index>(r.observed.size()) == m;
  if (all) {
    CovarianceUpdate(prior.P, s.C, s.R, options, &cu);
    r.innovation = y - s.C * prior.x;
  } else {
    const Eigen::MatrixXd Co = s.C(r.observed, Eigen::all);
    const Eigen::MatrixXd Ro = s.R(r.observed, r.observed);
    CovarianceUpdate(prior.P, Co, Ro, options, &cu);
    r.innovation = y(r.observed) - Co * prior.x;
  }
  r.estimate.x = prior.x;
  r.estimate.x.noalias() += cu.K * r.innovation;
  r.estimate.P = std::move(cu.P);
  const Eigen::VectorXd w = cu.S_llt.matrixL().solve(r.innovation);
  const double log_det = 2.0 * cu.S_llt.matrixLLT().diagonal().array().log().sum();
  r.log_likelihood = -0.5 * (static_cast<double>(r.observed.size()) * kLog2Pi + log_det + w.squaredNorm());
  r.innovation_cov = std::move(cu.S);
  r.gain = std::move(cu.K);
  return r;
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
  detail::HealthMonitor monitor(options.monitor_health);
  const Eigen::Index n = model.state_dim(), m = model.meas_dim();
  if (y.cols() != m) {
    throw Error("y: expected " + std::to_string(m) + (m == 1 ? " column" : " columns") +
                " (the model's measurement dimension), got " + std::to_string(y.rows()) + "x" +
                std::to_string(y.cols()));
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
  Estimate e{model.m0(), model.P0()};
  run.x_filt.row(0) = e.x.transpose();
  run.x_pred.row(0) = e.x.transpose();
  run.P_filt_diag.row(0) = e.P.diagonal().transpose();
  run.P_pred_diag.row(0) = e.P.diagonal().transpose();
  if (options.store_covariances) {
    run.P_filt.reserve(static_cast<size_t>(T) + 1);
    run.P_pred.reserve(static_cast<size_t>(T) + 1);
    run.P_filt.push_back(e.P);
    run.P_pred.push_back(e.P);
  }
  // Steady-state fast path (FilterRunOptions::steady_state_tolerance): the frozen gain, S_k factor
  // and covariances; e.P keeps the frozen P_{k|k} so that a missing measurement can resume the
  // full recursion from it.
  const double tol = options.steady_state_tolerance;
  if (!(tol >= 0.0 && tol <= 1e-2)) {
    throw Error("options.steady_state_tolerance: expected a value in [0, 1e-2], got " + std::to_string(tol));
  }
  const bool fast = tol > 0.0 && model.time_invariant();
  bool frozen = false;
  Eigen::MatrixXd K_ss, P_pred_ss;
  Eigen::LLT<Eigen::MatrixXd> S_ss;
  Eigen::VectorXd x_pred(n), nu(m), w(m);
  double log_det_ss = 0.0;
  for (int k = 1; k <= T; ++k) {
    const StepPtr s = model.step(k);
    if (frozen && y.row(k - 1).allFinite()) {
      x_pred.noalias() = s->A * e.x;
      nu = y.row(k - 1).transpose();
      nu.noalias() -= s->C * x_pred;
      e.x = x_pred;
      e.x.noalias() += K_ss * nu;
      w = S_ss.matrixL().solve(nu);
      run.x_pred.row(k) = x_pred.transpose();
      run.P_pred_diag.row(k) = run.P_pred_diag.row(k - 1);
      run.innovations.row(k - 1) = nu.transpose();
      run.num_observed[static_cast<size_t>(k - 1)] = static_cast<int>(m);
      run.log_likelihood_terms(k - 1) = -0.5 * (static_cast<double>(m) * kLog2Pi + log_det_ss + w.squaredNorm());
      run.x_filt.row(k) = e.x.transpose();
      run.P_filt_diag.row(k) = run.P_filt_diag.row(k - 1);
      if (options.store_covariances) {
        run.P_pred.push_back(P_pred_ss);
        run.P_filt.push_back(e.P);
      }
      ++run.steady_state_steps;
      if (options.progress) options.progress(k, T);
      continue;
    }
    frozen = false;
    Estimate pred = Predict(e, *s, options.filter);
    run.x_pred.row(k) = pred.x.transpose();
    run.P_pred_diag.row(k) = pred.P.diagonal().transpose();
    UpdateResult u;
    try {
      u = Update(pred, *s, y.row(k - 1).transpose(), options.filter);
    } catch (const Error& err) {
      std::string what = err.what();
      if (what.rfind("y: ", 0) == 0) what = what.substr(3);
      throw Error("y (row " + std::to_string(k - 1) + "): " + what);
    } catch (const NumericalError& err) {
      throw NumericalError("step " + std::to_string(k) + ": " + err.what());
    }
    for (size_t i = 0; i < u.observed.size(); ++i) run.innovations(k - 1, u.observed[i]) = u.innovation(i);
    run.num_observed[static_cast<size_t>(k - 1)] = static_cast<int>(u.observed.size());
    run.log_likelihood_terms(k - 1) = u.log_likelihood;
    detail::RequireFiniteStep(k, u.estimate.x, u.estimate.P, u.log_likelihood);
    monitor.Observe(k, u.estimate.P, u.innovation, u.innovation_cov);
    if (fast && static_cast<Eigen::Index>(u.observed.size()) == m &&
        (u.estimate.P - e.P).norm() <= tol * u.estimate.P.norm()) {
      frozen = true;
      K_ss = u.gain;
      P_pred_ss = pred.P;
      S_ss.compute(u.innovation_cov);
      log_det_ss = 2.0 * S_ss.matrixLLT().diagonal().array().log().sum();
    }
    if (options.store_covariances) run.P_pred.push_back(std::move(pred.P));
    e = std::move(u.estimate);
    run.x_filt.row(k) = e.x.transpose();
    run.P_filt_diag.row(k) = e.P.diagonal().transpose();
    if (options.store_covariances) run.P_filt.push_back(e.P);
    if (options.progress) options.progress(k, T);
  }
  run.log_likelihood = run.log_likelihood_terms.sum();
  run.health = monitor.Finish();
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

KalmanSchedule ComputeKalmanSchedule(const Model& model, int steps, const KalmanFilterOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw Error("options: " + why);
  if (options.form != FilterForm::kConventional) return detail::FactoredKalmanSchedule(model, steps, options);
  const int T = model.ResolveSteps(steps);
  KalmanSchedule sch;
  sch.filter_gain.resize(static_cast<size_t>(T) + 1);
  sch.P_pred.reserve(static_cast<size_t>(T) + 1);
  sch.P_filt.reserve(static_cast<size_t>(T) + 1);
  sch.P_pred.push_back(model.P0());
  sch.P_filt.push_back(model.P0());
  Estimate e{Eigen::VectorXd::Zero(model.state_dim()), model.P0()};
  CovarianceUpdateResult cu;
  for (int k = 1; k <= T; ++k) {
    const StepPtr s = model.step(k);
    e = Predict(e, *s, options);
    CovarianceUpdate(e.P, s->C, s->R, options, &cu);
    sch.P_pred.push_back(e.P);
    sch.P_filt.push_back(cu.P);
    sch.filter_gain[static_cast<size_t>(k)] = cu.K;
    e.P = std::move(cu.P);
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

LinearFilter ConstantGainFilter(const ModelStep& design, const Eigen::Ref<const Eigen::MatrixXd>& filter_gain,
                                const Eigen::Ref<const Eigen::VectorXd>& z0) {
  RequireShape("filter_gain", filter_gain, design.state_dim(), design.meas_dim());
  LinearFilterStep f;
  f.Phi = design.A;
  f.Phi.noalias() -= filter_gain * (design.C * design.A);
  f.K = filter_gain;
  return LinearFilter(std::move(f), z0);
}

}  // namespace kfx
