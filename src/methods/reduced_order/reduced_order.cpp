// Reduced-order filters of paper 001 (Sec. II one-step, Sec. III two-step), their LinearFilter
// form and the weighted cost through the exact-performance engine. Equations: reduced_order.hpp.
#include "kfx/reduced_order.hpp"

#include <cmath>
#include <limits>

#include "kfx/error.hpp"
#include "kfx/kalman_filter.hpp"
#include "kfx/validation.hpp"
#include "methods/reduced_order/reduced_order_internal.hpp"

namespace kfx {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

// ---- WeightSchedule ---------------------------------------------------------------------------

namespace {

MatrixXd RowPseudoInverse(const MatrixXd& L, const std::string& name) {
  RequireFinite(name, L);
  if (L.rows() == 0 || L.rows() > L.cols()) {
    throw Error(name + ": expected q x n with 1 <= q <= n, got " + ShapeString(L));
  }
  const MatrixXd LLt = L * L.transpose();
  Eigen::SelfAdjointEigenSolver<MatrixXd> es(LLt);
  const double top = es.eigenvalues().maxCoeff();
  if (!(top > 0.0) || es.eigenvalues().minCoeff() <= 1e-12 * top) {
    throw Error(name + ": expected full row rank (L L^T nonsingular)");
  }
  return L.transpose() * LLt.llt().solve(MatrixXd::Identity(L.rows(), L.rows()));
}

}  // namespace

WeightSchedule::WeightSchedule(Eigen::MatrixXd constant) {
  pinv_.push_back(RowPseudoInverse(constant, "L"));
  rows_ = constant.rows();
  cols_ = constant.cols();
  L_.push_back(std::move(constant));
}

WeightSchedule::WeightSchedule(std::vector<Eigen::MatrixXd> per_step) {
  if (per_step.empty()) throw Error("L: expected at least one weight matrix");
  rows_ = per_step[0].rows();
  cols_ = per_step[0].cols();
  for (size_t i = 0; i < per_step.size(); ++i) {
    const std::string name = "L[" + std::to_string(i) + "]";
    RequireShape(name, per_step[i], rows_, cols_);
    pinv_.push_back(RowPseudoInverse(per_step[i], name));
  }
  L_ = std::move(per_step);
}

const Eigen::MatrixXd& WeightSchedule::at(int k) const {
  if (L_.empty()) throw Error("L: empty weight schedule");
  if (L_.size() == 1) return L_[0];
  const int i = std::max(k, 1) - 1;
  if (i >= size()) {
    throw Error("L: expected a weight for k = " + std::to_string(k) + ", the schedule has " + std::to_string(size()));
  }
  return L_[static_cast<size_t>(i)];
}

const Eigen::MatrixXd& WeightSchedule::pinv_at(int k) const {
  at(k);  // range check
  if (pinv_.size() == 1) return pinv_[0];
  return pinv_[static_cast<size_t>(std::max(k, 1) - 1)];
}

bool ReducedOrderOptions::IsValid(std::string* error) const {
  if (!(rank_tolerance > 0.0 && rank_tolerance < 1.0)) {
    if (error) *error = "rank_tolerance: expected a number in (0, 1)";
    return false;
  }
  return true;
}

// ---- shared pieces ----------------------------------------------------------------------------

namespace detail {

MatrixXd SymmetricPseudoInverse(const MatrixXd& S, double rank_tolerance, bool* singular) {
  const Index q = S.rows();
  if (q == 0) return S;
  Eigen::SelfAdjointEigenSolver<MatrixXd> es(0.5 * (S + S.transpose()));
  const VectorXd& w = es.eigenvalues();
  const double top = std::max(w.cwiseAbs().maxCoeff(), 0.0);
  const double cut = rank_tolerance * top;
  VectorXd inv = VectorXd::Zero(q);
  bool sing = false;
  for (Index i = 0; i < q; ++i) {
    if (top > 0.0 && w(i) > cut) {
      inv(i) = 1.0 / w(i);
    } else {
      sing = true;
    }
  }
  if (singular) *singular = *singular || sing;
  return es.eigenvectors() * inv.asDiagonal() * es.eigenvectors().transpose();
}

MatrixXd SolveRight(const MatrixXd& X, const MatrixXd& V, const std::string& what) {
  // X V^{-1} for symmetric positive definite V.
  Eigen::LLT<MatrixXd> llt(V);
  if (llt.info() != Eigen::Success) throw NumericalError(what + ": innovation covariance is not positive definite");
  return llt.solve(X.transpose()).transpose();
}

void FinishScheduleSummary(const char* computation, int T, std::chrono::steady_clock::time_point start,
                           const std::vector<int>* singular_steps, Summary* summary) {
  summary->computation = computation;
  summary->method = "oblique projections (001)";
  summary->termination = Termination::kConverged;
  summary->iterations = T;
  if (singular_steps && !singular_steps->empty()) {
    std::string ks;
    for (const int k : *singular_steps) ks += (ks.empty() ? "" : ", ") + std::to_string(k);
    summary->message = "pseudo-inverse of a singular L M L^T at k = " + ks;
  }
  summary->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

int PrepareRun(const Model& model, const WeightSchedule& L, const ReducedOrderOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw Error("options." + why);
  if (L.size() == 0) throw Error("L: expected a weight schedule");
  if (L.cols() != model.state_dim()) {
    throw Error("L: expected " + std::to_string(model.state_dim()) + " columns (the state dimension), got " +
                std::to_string(L.cols()));
  }
  const int T = model.ResolveSteps(options.steps);
  if (T < 1) throw Error("options.steps: expected at least 1 step");
  if (L.size() > 1 && L.size() < T) {
    throw Error("L: expected " + std::to_string(T) + " weights (one per step), got " + std::to_string(L.size()));
  }
  return T;
}

LinearFilter OneStepFilter(const VectorXd& xi1, const std::vector<MatrixXd>& Ae, const std::vector<MatrixXd>& Be,
                           const std::function<MatrixXd(int)>& output, Index m, int T) {
  const Index ne = xi1.size(), nz = ne + m;
  std::vector<LinearFilterStep> steps;
  steps.reserve(static_cast<size_t>(T));
  for (int k = 1; k <= T; ++k) {
    LinearFilterStep s;
    s.Phi = MatrixXd::Zero(nz, nz);
    if (k == 1) {
      s.Phi.topLeftCorner(ne, ne).setIdentity();
    } else {
      s.Phi.topLeftCorner(ne, ne) = Ae[static_cast<size_t>(k - 2)];
      s.Phi.topRightCorner(ne, m) = Be[static_cast<size_t>(k - 2)];
    }
    s.K = MatrixXd::Zero(nz, m);
    s.K.bottomRows(m).setIdentity();
    const MatrixXd O = output(k);
    s.O = MatrixXd::Zero(O.rows(), nz);
    s.O.leftCols(ne) = O;
    steps.push_back(std::move(s));
  }
  VectorXd z0 = VectorXd::Zero(nz);
  z0.head(ne) = xi1;
  const MatrixXd O0 = MatrixXd::Zero(output(1).rows(), nz);
  return LinearFilter(std::move(steps), z0, O0);
}

LinearFilter TwoStepFilter(const VectorXd& xi1, const std::vector<MatrixXd>& Cf, const std::vector<MatrixXd>& Df,
                           const std::vector<MatrixXd>& Ad, const std::function<MatrixXd(int)>& output,
                           TwoStepOutput which, int T) {
  const Index ne = xi1.size(), nz = 2 * ne, m = Df[0].cols();
  std::vector<LinearFilterStep> steps;
  steps.reserve(static_cast<size_t>(T));
  for (int k = 1; k <= T; ++k) {
    const size_t i = static_cast<size_t>(k - 1);
    LinearFilterStep s;
    s.Phi = MatrixXd::Zero(nz, nz);
    if (k == 1) {
      s.Phi.topLeftCorner(ne, ne) = Cf[0];
      s.Phi.bottomLeftCorner(ne, ne).setIdentity();
    } else {
      const MatrixXd& A = Ad[static_cast<size_t>(k - 2)];
      s.Phi.topLeftCorner(ne, ne) = Cf[i] * A;
      s.Phi.bottomLeftCorner(ne, ne) = A;
    }
    s.K = MatrixXd::Zero(nz, m);
    s.K.topRows(ne) = Df[i];
    const MatrixXd O = output(k);
    s.O = MatrixXd::Zero(O.rows(), nz);
    if (which == TwoStepOutput::kDataAssimilation) {
      s.O.leftCols(ne) = O;
    } else {
      s.O.rightCols(ne) = O;
    }
    steps.push_back(std::move(s));
  }
  VectorXd z0 = VectorXd::Zero(nz);
  z0.head(ne) = xi1;
  const MatrixXd O0 = MatrixXd::Zero(output(1).rows(), nz);
  return LinearFilter(std::move(steps), z0, O0);
}

}  // namespace detail

namespace {

using detail::SolveRight;
using detail::SymmetricPseudoInverse;

// tau = M L^T (L M L^T)^+ L and the split M = tau M tau^T + (I - tau) M (I - tau)^T.
struct Projection {
  MatrixXd tau, kept, lost;  // tau, tau M tau^T, (I - tau) M (I - tau)^T
};

Projection Project(const MatrixXd& M, const MatrixXd& L, double tol, bool* singular) {
  const MatrixXd ML = M * L.transpose();
  const MatrixXd W = L * ML;
  Projection p;
  p.tau = ML * SymmetricPseudoInverse(W, tol, singular) * L;
  p.kept = p.tau * M * p.tau.transpose();
  Symmetrize(p.kept);
  const MatrixXd I_tau = MatrixXd::Identity(M.rows(), M.cols()) - p.tau;
  p.lost = I_tau * M * I_tau.transpose();
  Symmetrize(p.lost);
  return p;
}

double WeightedTrace(const MatrixXd& L, const MatrixXd& Q) { return (L * Q * L.transpose()).trace(); }

// Second moment of x_1 (prediction before y_1) and its mean.
void PriorPrediction(const Model& model, MatrixXd* second_moment, VectorXd* mean) {
  const StepPtr s1 = model.step(1);
  *mean = s1->A * model.m0();
  *second_moment = s1->A * model.P0() * s1->A.transpose() + s1->Q + (*mean) * mean->transpose();
  Symmetrize(*second_moment);
}

}  // namespace

ReducedOrderOneStep ComputeReducedOrderOneStep(const Model& model, const WeightSchedule& L,
                                               const ReducedOrderOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const int T = detail::PrepareRun(model, L, options);
  const double tol = options.rank_tolerance;
  ReducedOrderOneStep out;
  out.Q.resize(static_cast<size_t>(T) + 1);
  out.Qhat.resize(static_cast<size_t>(T) + 1);
  out.tau.resize(static_cast<size_t>(T) + 1);
  out.cost = VectorXd::Constant(T + 1, std::numeric_limits<double>::quiet_NaN());
  out.meas_dim = model.meas_dim();

  MatrixXd Qt1;
  VectorXd mu;
  PriorPrediction(model, &Qt1, &mu);
  out.xi1 = L.at(1) * mu;
  {
    bool sing = false;
    const Projection p = Project(mu * mu.transpose(), L.at(1), tol, &sing);
    out.Qhat[1] = p.kept;
    out.Q[1] = Qt1 - p.kept;
    Symmetrize(out.Q[1]);
  }
  out.cost(1) = WeightedTrace(L.at(1), out.Q[1]);
  for (int k = 1; k < T; ++k) {
    const StepPtr sk = model.step(k), sn = model.step(k + 1);
    const MatrixXd& Q = out.Q[static_cast<size_t>(k)];
    const MatrixXd& Qh = out.Qhat[static_cast<size_t>(k)];
    const MatrixXd& Lk = L.at(k);
    const MatrixXd& Ln = L.at(k + 1);
    const MatrixXd QCt = Q * sk->C.transpose();
    MatrixXd Vt = sk->C * QCt + sk->R;
    Symmetrize(Vt);
    const MatrixXd KQ = SolveRight(QCt, Vt, "step " + std::to_string(k));  // Q C^T Vt^{-1}
    MatrixXd S = KQ * QCt.transpose();                                     // Q C^T Vt^{-1} C Q
    Symmetrize(S);
    bool sing = false;
    const MatrixXd Gt = Qh * Lk.transpose() * SymmetricPseudoInverse(Lk * Qh * Lk.transpose(), tol, &sing);  // G_k^T
    const MatrixXd LA = Ln * sn->A;
    out.Be.push_back(LA * KQ);
    out.Ae.push_back(LA * (Gt - KQ * (sk->C * Gt)));
    MatrixXd M = sn->A * (Qh + S) * sn->A.transpose();
    Symmetrize(M);
    bool sing_next = false;
    const Projection p = Project(M, Ln, tol, &sing_next);
    if (sing_next) out.singular_steps.push_back(k + 1);
    out.tau[static_cast<size_t>(k) + 1] = p.tau;
    out.Qhat[static_cast<size_t>(k) + 1] = p.kept;
    MatrixXd Qn = sn->A * (Q - S) * sn->A.transpose() + sn->Q + p.lost;
    Symmetrize(Qn);
    out.Q[static_cast<size_t>(k) + 1] = std::move(Qn);
    out.cost(k + 1) = WeightedTrace(Ln, out.Q[static_cast<size_t>(k) + 1]);
  }
  detail::FinishScheduleSummary("one-step reduced-order filter schedule", T, start, &out.singular_steps, &out.summary);
  return out;
}

LinearFilter ReducedOrderOneStepAsLinearFilter(const ReducedOrderOneStep& s, const WeightSchedule& L) {
  const int T = static_cast<int>(s.Q.size()) - 1;
  if (T < 1 || static_cast<int>(s.Ae.size()) != T - 1) throw Error("s: expected a computed one-step schedule");
  return detail::OneStepFilter(
      s.xi1, s.Ae, s.Be, [&L](int k) { return L.pinv_at(k); }, s.meas_dim, T);
}

ReducedOrderTwoStep ComputeReducedOrderTwoStep(const Model& model, const WeightSchedule& L,
                                               const ReducedOrderOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  const int T = detail::PrepareRun(model, L, options);
  const double tol = options.rank_tolerance;
  ReducedOrderTwoStep out;
  const size_t N = static_cast<size_t>(T) + 1;
  out.Cf.resize(N);
  out.Df.resize(N);
  out.Qf.resize(N);
  out.Qhatf.resize(N);
  out.Qda.resize(N);
  out.Qhatda.resize(N);
  out.tau_da.resize(N);
  out.tau_f.resize(N);
  out.cost_da = VectorXd::Constant(T + 1, std::numeric_limits<double>::quiet_NaN());
  out.cost_f = out.cost_da;

  MatrixXd Qt1;
  VectorXd mu;
  PriorPrediction(model, &Qt1, &mu);
  out.xi1 = L.at(1) * mu;
  {
    bool sing = false;
    const Projection p = Project(mu * mu.transpose(), L.at(1), tol, &sing);
    out.Qhatf[1] = p.kept;
    out.Qf[1] = Qt1 - p.kept;
    Symmetrize(out.Qf[1]);
  }
  for (int k = 1; k <= T; ++k) {
    const size_t i = static_cast<size_t>(k);
    const StepPtr sk = model.step(k);
    const MatrixXd& Lk = L.at(k);
    const MatrixXd& Qf = out.Qf[i];
    const MatrixXd& Qhf = out.Qhatf[i];
    out.cost_f(k) = WeightedTrace(Lk, Qf);
    // Data assimilation (3.16)-(3.17), (3.29)-(3.33).
    const MatrixXd QCt = Qf * sk->C.transpose();
    MatrixXd Vf = sk->C * QCt + sk->R;
    Symmetrize(Vf);
    const MatrixXd KQ = SolveRight(QCt, Vf, "step " + std::to_string(k));
    MatrixXd S = KQ * QCt.transpose();
    Symmetrize(S);
    bool sing = false;
    const MatrixXd Gt = Qhf * Lk.transpose() * SymmetricPseudoInverse(Lk * Qhf * Lk.transpose(), tol, &sing);
    out.Df[i] = Lk * KQ;
    out.Cf[i] = Lk * (Gt - KQ * (sk->C * Gt));
    bool sing_da = false;
    const Projection pda = Project(Qhf + S, Lk, tol, &sing_da);
    if (sing_da) out.singular_steps.push_back(k);
    out.tau_da[i] = pda.tau;
    out.Qhatda[i] = pda.kept;
    out.Qda[i] = Qf - S + pda.lost;
    Symmetrize(out.Qda[i]);
    out.cost_da(k) = WeightedTrace(Lk, out.Qda[i]);
    if (k == T) break;
    // Forecast (3.42), (3.46)-(3.47).
    const StepPtr sn = model.step(k + 1);
    const MatrixXd& Ln = L.at(k + 1);
    const MatrixXd& Qhda = out.Qhatda[i];
    bool unused = false;
    const MatrixXd Gdat = Qhda * Lk.transpose() * SymmetricPseudoInverse(Lk * Qhda * Lk.transpose(), tol, &unused);
    out.Ada.push_back(Ln * sn->A * Gdat);
    MatrixXd Mf = sn->A * Qhda * sn->A.transpose();
    Symmetrize(Mf);
    const Projection pf = Project(Mf, Ln, tol, &unused);
    out.tau_f[i + 1] = pf.tau;
    out.Qhatf[i + 1] = pf.kept;
    out.Qf[i + 1] = sn->A * out.Qda[i] * sn->A.transpose() + sn->Q + pf.lost;
    Symmetrize(out.Qf[i + 1]);
  }
  detail::FinishScheduleSummary("two-step reduced-order filter schedule", T, start, &out.singular_steps, &out.summary);
  return out;
}

const char* ToString(TwoStepOutput output) {
  switch (output) {
    case TwoStepOutput::kDataAssimilation:
      return "data_assimilation";
    case TwoStepOutput::kForecast:
      return "forecast";
  }
  return "unknown";
}

LinearFilter ReducedOrderTwoStepAsLinearFilter(const ReducedOrderTwoStep& s, const WeightSchedule& L,
                                               TwoStepOutput output) {
  const int T = static_cast<int>(s.Qf.size()) - 1;
  if (T < 1 || static_cast<int>(s.Ada.size()) != T - 1) throw Error("s: expected a computed two-step schedule");
  std::vector<MatrixXd> Cf(s.Cf.begin() + 1, s.Cf.end()), Df(s.Df.begin() + 1, s.Df.end());
  return detail::TwoStepFilter(
      s.xi1, Cf, Df, s.Ada, [&L](int k) { return L.pinv_at(k); }, output, T);
}

// ---- costs ------------------------------------------------------------------------------------

Eigen::VectorXd WeightedCost(const Model& truth, const LinearFilter& filter, const WeightSchedule& L,
                             const ReducedOrderOptions& options, PerformanceResult* result) {
  if (L.cols() != truth.state_dim()) throw Error("L: expected as many columns as the model has states");
  std::string why;
  if (!options.IsValid(&why)) throw Error("options." + why);
  PerformanceOptions po;
  po.steps = options.steps;
  po.store_error_moments = true;
  PerformanceResult r = ExactPerformance(truth, filter, po);
  const int T = static_cast<int>(r.error_moment.size()) - 1;
  VectorXd J(T + 1);
  for (int k = 0; k <= T; ++k) J(k) = WeightedTrace(L.at(k), r.error_moment[static_cast<size_t>(k)]);
  if (result) *result = std::move(r);
  return J;
}

KalmanWeightedCosts KalmanCosts(const Model& model, const WeightSchedule& L, const ReducedOrderOptions& options) {
  if (L.cols() != model.state_dim()) throw Error("L: expected as many columns as the model has states");
  std::string why;
  if (!options.IsValid(&why)) throw Error("options." + why);
  KalmanScheduleOptions schedule_options;
  schedule_options.steps = options.steps;
  const KalmanSchedule ks = ComputeKalmanSchedule(model, schedule_options);
  const int T = static_cast<int>(ks.P_pred.size()) - 1;
  KalmanWeightedCosts c;
  c.predictor.resize(T + 1);
  c.filter.resize(T + 1);
  for (int k = 0; k <= T; ++k) {
    c.predictor(k) = WeightedTrace(L.at(k), ks.P_pred[static_cast<size_t>(k)]);
    c.filter(k) = WeightedTrace(L.at(k), ks.P_filt[static_cast<size_t>(k)]);
  }
  return c;
}

}  // namespace kfx
