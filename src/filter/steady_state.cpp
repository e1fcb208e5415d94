// SteadyStateDare: the steady-state Kalman filter of a time-invariant step in kfx's pairing of the
// noises (cov(w_k, v_k) = S, w_k producing x_k), through the equivalent filter DARE of the riccati layer.
#include <string>

#include "kfx/error.hpp"
#include "kfx/kalman_filter.hpp"
#include "kfx/validation.hpp"

namespace kfx {

using Eigen::MatrixXd;

DareSolution SteadyStateDare(const ModelStep& s, const DareOptions& options) {
  if (!s.has_cross_covariance() || s.S.size() == 0) return SolveFilterDare(s.A, s.C, s.Q, s.R, options);
  const Eigen::Index n = s.state_dim(), m = s.meas_dim();
  RequireShape("A", s.A, n, n);
  RequireShape("C", s.C, m, n);
  RequireShape("S", s.S, n, m);
  RequireFinite("S", s.S);
  // y_k = C A x_{k-1} + (C w_k + v_k): the measurement of x_{k-1} with noise v~ = C w + v, which is
  // correlated with the noise w_k that leaves x_{k-1} (the riccati layer's pairing). Its predictor
  // DARE solution is P_{k|k} of the model, its predictor gain the model's filter gain K_f.
  const MatrixXd CA = s.C * s.A;
  const MatrixXd QCt = s.Q * s.C.transpose();
  MatrixXd R_eq = s.C * QCt;
  R_eq += s.C * s.S;
  R_eq += s.S.transpose() * s.C.transpose();
  R_eq += s.R;
  R_eq = 0.5 * (R_eq + R_eq.transpose()).eval();
  const MatrixXd S_eq = QCt + s.S;
  DareSolution eq;
  try {
    eq = SolveFilterDare(s.A, CA, s.Q, R_eq, S_eq, MatrixXd(0, 0), options);
  } catch (const Error& e) {
    throw Error(std::string("S: the steady-state filter of a step with a cross-covariance needs the covariance of "
                            "C w_k + v_k, C Q C^T + C S + S^T C^T + R, positive definite (") +
                e.what() + ")");
  }
  DareSolution out = eq;
  out.P_filt = eq.P_pred;
  out.P_pred = s.A * eq.P_pred * s.A.transpose() + s.Q;
  out.P_pred = 0.5 * (out.P_pred + out.P_pred.transpose()).eval();
  out.innovation_cov = eq.innovation_cov;  // C P_pred C^T + C S + S^T C^T + R
  out.filter_gain = eq.predictor_gain;     // (P_pred C^T + S) W^{-1}
  out.predictor_gain = s.A * out.filter_gain;
  return out;
}

}  // namespace kfx
