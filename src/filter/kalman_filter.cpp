// The public entry points of the Kalman filter (kfx/kalman_filter.hpp): argument checks, then the
// form chosen by detail::KalmanFormFor (filter_form.hpp); the Rauch-Tung-Striebel smoother and the
// Kalman filter as a LinearFilter.
#include "kfx/kalman_filter.hpp"

#include <cmath>
#include <string>
#include <vector>

#include "filter/filter_form.hpp"
#include "kfx/error.hpp"
#include "kfx/validation.hpp"

namespace kfx {

namespace {

// The one-step functions take an estimate and a step from the caller, so they check both as a Model
// checks its prior and its steps (docs/robustness.md, class 10): x finite of length n, P n x n,
// symmetric and PSD within kfx's tolerances; the step by ValidateStep. The KalmanFilter class steps
// its own model (validated) and its own estimates, so it calls the form directly.
void CheckEstimate(const Estimate& e, Eigen::Index n, const char* what) {
  RequireVector(std::string(what) + ".x", e.x, n);
  RequireShape(std::string(what) + ".P", e.P, n, n);
  RequirePositiveSemidefinite(std::string(what) + ".P", e.P);
}

void CheckStep(const ModelStep& s) {
  RequireSquare("step.A", s.A);
  ValidateStep(s, s.A.rows(), s.C.rows(), "step.");
}

// The single steps on checked arguments, as RunFilter's loop does them (filter_form.cpp, RunLoop): the form's
// predict, then G_k g_k added to the mean; D_k g_k taken off y_k (NaN entries stay missing), then the form's
// update (with S: the correlated update).
Estimate PredictWithInput(const Estimate& e, const ModelStep& s, const KnownInputTerms& input,
                          const KalmanFilterOptions& options) {
  Estimate out = detail::KalmanFormFor(options, s.A.rows(), s.C.rows()).Predict(e, s, options);
  if (input.state.size() > 0) out.x += input.state;
  return out;
}

UpdateResult UpdateWithInput(const Estimate& prior, const ModelStep& s, const Eigen::Ref<const Eigen::VectorXd>& y,
                             const KnownInputTerms& input, const KalmanFilterOptions& options) {
  const detail::KalmanForm& form = detail::KalmanFormFor(options, s.A.rows(), s.C.rows());
  if (input.measurement.size() == 0) return form.Update(prior, s, y, options);
  const Eigen::VectorXd y_net = y - input.measurement;
  return form.Update(prior, s, y_net, options);
}

void RequireMeasurementLength(const Eigen::Ref<const Eigen::VectorXd>& y, Eigen::Index m) {
  if (y.size() != m) {
    throw Error("y: expected a measurement of length " + std::to_string(m) + ", got length " +
                std::to_string(y.size()));
  }
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

Estimate Predict(const Estimate& e, const ModelStep& s, const Eigen::Ref<const Eigen::VectorXd>& g,
                 const KalmanFilterOptions& options) {
  CheckStep(s);
  CheckEstimate(e, s.A.rows(), "estimate");
  return PredictWithInput(e, s, KnownInputOf(s, g), options);
}

Estimate Predict(const Estimate& e, const ModelStep& s, const KalmanFilterOptions& options) {
  return Predict(e, s, Eigen::VectorXd(), options);
}

UpdateResult Update(const Estimate& prior, const ModelStep& s, const Eigen::Ref<const Eigen::VectorXd>& y,
                    const Eigen::Ref<const Eigen::VectorXd>& g, const KalmanFilterOptions& options) {
  CheckStep(s);
  CheckEstimate(prior, s.A.rows(), "prior");
  RequireMeasurementLength(y, s.C.rows());
  return UpdateWithInput(prior, s, y, KnownInputOf(s, g), options);
}

UpdateResult Update(const Estimate& prior, const ModelStep& s, const Eigen::Ref<const Eigen::VectorXd>& y,
                    const KalmanFilterOptions& options) {
  return Update(prior, s, y, Eigen::VectorXd(), options);
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

void KalmanFilter::Predict() { Predict(Eigen::VectorXd()); }

void KalmanFilter::Predict(const Eigen::Ref<const Eigen::VectorXd>& g) {
  const StepPtr s = model_.step(k_ + 1);
  estimate_ = PredictWithInput(estimate_, *s, KnownInputOf(*s, g), options_);
  ++k_;
  predicted_ = true;
}

UpdateResult KalmanFilter::Update(const Eigen::Ref<const Eigen::VectorXd>& y) { return Update(y, Eigen::VectorXd()); }

UpdateResult KalmanFilter::Update(const Eigen::Ref<const Eigen::VectorXd>& y,
                                  const Eigen::Ref<const Eigen::VectorXd>& g) {
  if (!predicted_) throw Error("Update: expected a Predict() before each Update() (k = " + std::to_string(k_) + ")");
  RequireMeasurementLength(y, model_.meas_dim());
  const StepPtr s = model_.step(k_);
  UpdateResult r = UpdateWithInput(estimate_, *s, y, KnownInputOf(*s, g), options_);
  estimate_ = r.estimate;
  predicted_ = false;
  return r;
}

UpdateResult KalmanFilter::Step(const Eigen::Ref<const Eigen::VectorXd>& y) { return Step(y, Eigen::VectorXd()); }

UpdateResult KalmanFilter::Step(const Eigen::Ref<const Eigen::VectorXd>& y,
                                const Eigen::Ref<const Eigen::VectorXd>& g) {
  Predict(g);
  return Update(y, g);
}

FilterRun RunFilter(const Model& model, const TimeSeries& y, const FilterRunOptions& options) {
  return RunFilter(model, y, TimeSeries(0, 0), options);
}

FilterRun RunFilter(const Model& model, const TimeSeries& y, const TimeSeries& g, const FilterRunOptions& options) {
  std::string why;
  if (!options.filter.IsValid(&why)) throw Error("options.filter: " + why);
  const Eigen::Index n = model.state_dim(), m = model.meas_dim();
  if (y.cols() != m) {
    throw Error("y: expected " + std::to_string(m) + (m == 1 ? " column" : " columns") +
                " (the model's measurement dimension), got " + ShapeString(y.rows(), y.cols()));
  }
  const int T = model.ResolveSteps(static_cast<int>(y.rows()), "y (rows)");
  const double tol = options.steady_state_tolerance;
  if (!(tol >= 0.0 && tol <= 1e-2)) {
    throw Error("options.steady_state_tolerance: expected a value in [0, 1e-2], got " + std::to_string(tol));
  }
  RequireKnownInput(model, g, T);
  return detail::KalmanFormFor(options.filter, n, m).Run(model, y, g, options, T);
}

namespace {

// X = P^{-1} B by a Cholesky solve, or by a complete orthogonal decomposition (the pseudo-inverse) when P
// is singular to 1e-8 of its largest pivot.
Eigen::MatrixXd SolveCovariance(const Eigen::MatrixXd& P, const Eigen::MatrixXd& B) {
  Eigen::LLT<Eigen::MatrixXd> llt(P);
  if (llt.info() == Eigen::Success) {
    const double dmin = llt.matrixLLT().diagonal().minCoeff();
    const double dmax = llt.matrixLLT().diagonal().maxCoeff();
    if (dmin > 1e-8 * dmax) return llt.solve(B);
  }
  return Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd>(P).solve(B);
}

// One backward step of the smoother with a cross-covariance S of step k+1 (issue 22; `o` the observed
// entries of y_{k+1}). Given x_{k+1} and y_{k+1}, x_k is independent of the later measurements; with
// Sigma = S_o R_oo^{-1}, w_{k+1} = Sigma v_o + w'' (w'' independent of v_o, x_k), so
//   x_{k+1} - Sigma v_o - G g = A x_k + w'',   P' = P_{k+1|k} - Sigma S_o^T,   J' = P_{k|k} A^T P'^{-1},
//   x_{k|T} = x_{k|k} + J' (x_{k+1|T} - x_{k+1|k} - Sigma (y_o - D_o g - C_o x_{k+1|T})),
//   P_{k|T} = P_{k|k} - J' A P_{k|k} + J' N P_{k+1|T} N^T J'^T,   N = I + Sigma C_o.
// y_o - D_o g - C_o x_{k+1|T} is the innovation plus C_o (x_{k+1|k} - x_{k+1|T}). With S = 0 this is the
// RTS step.
void CorrelatedSmootherStep(const ModelStep& s, const std::vector<Eigen::Index>& o, const Eigen::VectorXd& nu_o,
                            const Eigen::MatrixXd& Pf, const Eigen::VectorXd& xf, const Eigen::MatrixXd& Pp,
                            const Eigen::VectorXd& xp, Eigen::VectorXd& xs, Eigen::MatrixXd& Ps) {
  const Eigen::Index n = Pf.rows();
  const Eigen::MatrixXd So = s.S(Eigen::all, o), Co = s.C(o, Eigen::all), Ro = s.R(o, o);
  const Eigen::MatrixXd Sigma = Ro.llt().solve(So.transpose()).transpose();
  Eigen::MatrixXd Pp2 = Pp - Sigma * So.transpose();
  Symmetrize(Pp2);
  const Eigen::MatrixXd APf = s.A * Pf;
  const Eigen::MatrixXd Jt = SolveCovariance(Pp2, APf);  // J'^T
  const Eigen::MatrixXd N = Eigen::MatrixXd::Identity(n, n) + Sigma * Co;
  const Eigen::VectorXd r = nu_o + Co * (xp - xs);
  xs = xf + Jt.transpose() * (xs - xp - Sigma * r);
  const Eigen::MatrixXd JN = Jt.transpose() * N;
  Eigen::MatrixXd next = Pf - Jt.transpose() * APf;
  next.noalias() += JN * Ps * JN.transpose();
  Symmetrize(next);
  Ps = std::move(next);
}

}  // namespace

SmootherRun RtsSmooth(const Model& model, const FilterRun& run, const SmootherOptions& options) {
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
    std::vector<Eigen::Index> o;  // observed entries of y_{k+1} at a step with S (empty: the RTS step)
    if (s->has_cross_covariance() && run.innovations.rows() >= k + 1) {
      for (Eigen::Index i = 0; i < run.innovations.cols(); ++i) {
        if (!std::isnan(run.innovations(k, i))) o.push_back(i);
      }
    }
    if (!o.empty()) {
      const Eigen::VectorXd nu_o = run.innovations.row(k)(o).transpose();
      CorrelatedSmootherStep(*s, o, nu_o, run.P_filt[kk], run.x_filt.row(k).transpose(), Pp,
                             run.x_pred.row(k + 1).transpose(), xs, Ps);
    } else {
      const Eigen::MatrixXd APf = s->A * run.P_filt[kk];    // A_{k+1} P_{k|k}  (= (P_{k|k} A^T)^T)
      const Eigen::MatrixXd Gt = SolveCovariance(Pp, APf);  // G_k^T = P_{k+1|k}^{-1} A_{k+1} P_{k|k}
      const Eigen::MatrixXd G = Gt.transpose();
      xs = run.x_filt.row(k).transpose() + G * (xs - run.x_pred.row(k + 1).transpose());
      Eigen::MatrixXd D = Ps - Pp;
      Ps = run.P_filt[kk];
      Ps.noalias() += G * D * Gt;
      Symmetrize(Ps);
    }
    sm.x.row(k) = xs.transpose();
    sm.P_diag.row(k) = Ps.diagonal().transpose();
    sm.P[kk] = Ps;
    if (options.progress) options.progress(T - k, T);
  }
  return sm;
}

KalmanSchedule ComputeKalmanSchedule(const Model& model, const KalmanScheduleOptions& schedule_options) {
  const KalmanFilterOptions& options = schedule_options.filter;
  std::string why;
  if (!options.IsValid(&why)) throw Error("options.filter: " + why);
  const int T = model.ResolveSteps(schedule_options.steps);
  return detail::KalmanFormFor(options, model.state_dim(), model.meas_dim(), detail::FormStorage::kDynamic)
      .Schedule(model, schedule_options, T);
}

namespace {

// The Kalman filter's known-input map (issue 22): x_{k|k} = (I - K C)(A x_{k-1|k-1} + G g) + K (y - D g), so
// Gamma = (I - K C) G - K D = G - K (C G + D); empty when the step has no G, D.
Eigen::MatrixXd KalmanInputMap(const ModelStep& s, const Eigen::MatrixXd& K) {
  if (!s.has_known_input()) return Eigen::MatrixXd();
  const Eigen::Index q = s.input_dim();
  Eigen::MatrixXd Gamma = s.G.size() > 0 ? s.G : Eigen::MatrixXd::Zero(s.state_dim(), q);
  Eigen::MatrixXd CGD = s.D.size() > 0 ? s.D : Eigen::MatrixXd::Zero(s.meas_dim(), q);
  if (s.G.size() > 0) CGD.noalias() += s.C * s.G;
  Gamma.noalias() -= K * CGD;
  return Gamma;
}

}  // namespace

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
    f.Gamma = KalmanInputMap(*s, K);
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
  f.Gamma = KalmanInputMap(design, filter_gain);
  return LinearFilter(std::move(f), z0);
}

}  // namespace kfx
