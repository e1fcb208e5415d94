// Algorithm 2.3 of paper 000, the RDE (20) check and the Sec. 6.1 approximation (subspace_filter.hpp).
#include "kfx/subspace_filter.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "base/stagnation.hpp"
#include "kfx/error.hpp"
#include "kfx/validation.hpp"

namespace kfx {

namespace {

using Eigen::MatrixXd;

// Moore-Penrose pseudoinverse of a symmetric PSD matrix (Remark 2.2): eigenvalues <= rtol * lambda_max
// are dropped. Returns the rank used, or -1 if the eigendecomposition failed.
int SymmetricPseudoInverse(const MatrixXd& S, double rtol, MatrixXd* out) {
  const Eigen::Index n = S.rows();
  out->setZero(n, n);
  if (n == 0) return 0;
  Eigen::SelfAdjointEigenSolver<MatrixXd> es(S);
  if (es.info() != Eigen::Success) return -1;
  const double lmax = es.eigenvalues().cwiseAbs().maxCoeff();
  if (!(lmax > 0)) return 0;
  int rank = 0;
  MatrixXd Vs(n, n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const double l = es.eigenvalues()(i);
    if (l > rtol * lmax) {
      Vs.col(rank) = es.eigenvectors().col(i) / std::sqrt(l);
      ++rank;
    }
  }
  out->noalias() = Vs.leftCols(rank) * Vs.leftCols(rank).transpose();
  return rank;
}

// A X A^T for symmetric X through the block operator (two applications).
MatrixXd Sandwich(const BlockOperator& apply, const MatrixXd& X) {
  const MatrixXd AX = apply(X);
  MatrixXd Y = apply(AX.transpose());
  Symmetrize(Y);
  return Y;
}

BlockOperator DenseOperator(const MatrixXd& A) {
  return [A](const MatrixXd& X) -> MatrixXd { return A * X; };
}

double RelativeChange(const MatrixXd& now, const MatrixXd& before) {
  const double d = (now - before).norm();
  const double s = now.norm();
  return s > 0 ? d / s : d;
}

}  // namespace

void ValidateSubspace(const Subspace& subspace, Eigen::Index N, double tol) {
  if (subspace.gram.size() > 0) {
    RequireShape("subspace.gram", subspace.gram, N, N);
    RequirePositiveDefinite("subspace.gram", subspace.gram);
  }
  RequireShape("subspace.projection", subspace.projection, -1, N);
  RequireFinite("subspace.projection", subspace.projection);
  if (subspace.projection.rows() < 1 || subspace.projection.rows() > N) {
    throw Error("subspace.projection: expected 1 to " + std::to_string(N) + " rows, got " +
                std::to_string(subspace.projection.rows()));
  }
  const MatrixXd adj = subspace.gram.size() == 0 ? MatrixXd(subspace.projection.transpose())
                                                 : MatrixXd(subspace.gram.llt().solve(subspace.projection.transpose()));
  const MatrixXd I = subspace.projection * adj;
  const double err = (I - MatrixXd::Identity(I.rows(), I.cols())).cwiseAbs().maxCoeff();
  if (!(err <= tol)) {
    throw Error("subspace.projection: expected Pi W^{-1} Pi^T = I (coordinates orthonormal in W), off by " +
                std::to_string(err));
  }
}

Subspace SubspaceFromBasis(const Eigen::Ref<const Eigen::MatrixXd>& basis, const Eigen::MatrixXd& gram) {
  const Eigen::Index N = basis.rows();
  RequireFinite("basis", basis);
  if (basis.cols() < 1 || basis.cols() > N) throw Error("basis: expected 1 to N columns, got " + ShapeString(basis));
  Subspace s;
  s.gram = gram;
  MatrixXd WE = basis;
  if (gram.size() > 0) {
    RequireShape("gram", gram, N, N);
    RequirePositiveDefinite("gram", gram);
    WE = gram * basis;
  }
  const MatrixXd G = basis.transpose() * WE;
  Eigen::LLT<MatrixXd> llt(G);
  if (llt.info() != Eigen::Success) throw Error("basis: expected full column rank (E^T W E not positive definite)");
  s.projection = llt.matrixL().solve(WE.transpose());
  return s;
}

MatrixXd ProjectionAdjoint(const Subspace& subspace) {
  if (subspace.gram.size() == 0) return subspace.projection.transpose();
  return subspace.gram.llt().solve(subspace.projection.transpose());
}

bool SubspaceFilterOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  if (steps < -1) return fail("steps: expected -1 or a number of steps >= 0");
  if (max_steps < 1) return fail("max_steps: expected >= 1");
  if (!(tolerance > 0 && tolerance <= 1e-2)) return fail("tolerance: expected a value in (0, 1e-2]");
  if (patience < 1) return fail("patience: expected >= 1");
  if (!(pinv_tolerance >= 0 && pinv_tolerance <= 1e-2)) return fail("pinv_tolerance: expected a value in [0, 1e-2]");
  return true;
}

namespace {

void CheckScheduleInput(const ModelStep& truth, const Eigen::MatrixXd& S0, const Subspace& subspace,
                        const SubspaceFilterOptions& options, const BlockOperator& applyA) {
  std::string why;
  if (!options.IsValid(&why)) throw Error("options." + why);
  const Eigen::Index N = truth.state_dim(), m = truth.meas_dim();
  ValidateStep(truth, N, m, "truth: ");
  RequireShape("S0", S0, N, N);
  RequirePositiveSemidefinite("S0", S0);
  ValidateSubspace(subspace, N);
  if (options.stationary_prior) {
    const MatrixXd resid = Sandwich(applyA, S0) + truth.Q - S0;
    const double rel = resid.norm() / std::max(S0.norm(), std::numeric_limits<double>::min());
    if (!(rel <= 1e-8)) {
      throw Error(
          "S0: expected the stationary state covariance (S0 = A S0 A^T + Q) with options.stationary_prior, "
          "relative residual " +
          std::to_string(rel));
    }
  }
}

// The RDE (20) as a second algorithm: P~ from its own previous P, the Kalman-type update, and the load
// M_k (21) = (I - Q_k Pi) X (I - Q_k Pi)^T with X = A Q_{k-1} S~_{k-1} Q_{k-1}^T A^T + K P~ C^T-part.
struct RdeCheck {
  MatrixXd P_rde, M_k;
  void Step(const ModelStep& truth, const BlockOperator& applyA, const MatrixXd& Pi, const MatrixXd& Q,
            const MatrixXd& X_load) {
    const MatrixXd& C = truth.C;
    MatrixXd Pt_r = Sandwich(applyA, P_rde);
    Pt_r += truth.Q;
    const MatrixXd PtCt_r = Pt_r * C.transpose();
    MatrixXd S_r = truth.R;
    S_r.noalias() += C * PtCt_r;
    Eigen::LLT<MatrixXd> llt_r(S_r);
    const MatrixXd K_r = llt_r.solve(PtCt_r.transpose()).transpose();
    MatrixXd Y = X_load;
    Y.noalias() -= (X_load * Pi.transpose()) * Q.transpose();
    M_k = Y;
    M_k.noalias() -= Q * (Pi * Y);
    Symmetrize(M_k);
    P_rde = Pt_r;
    P_rde.noalias() -= K_r * PtCt_r.transpose();
    P_rde += M_k;
    Symmetrize(P_rde);
  }
};

// The final fields of the schedule from the last step's matrices.
void FinishSchedule(const Eigen::MatrixXd& S0, const MatrixXd& S, const MatrixXd& St, const MatrixXd& St_prev,
                    const MatrixXd& AQ, SubspaceFilterSchedule* out) {
  if (out->steps > 0) {
    out->P_final = S;
    out->P_final.noalias() -= (out->Q * St) * out->Q.transpose();
    Symmetrize(out->P_final);
    out->P_pred = S;
    out->P_pred.noalias() -= (AQ * St_prev) * AQ.transpose();
    Symmetrize(out->P_pred);
  } else {
    out->P_final = S0;
    out->P_pred = S0;
  }
  out->S = S;
  out->S_tilde = St;
}

}  // namespace

SubspaceFilterSchedule ComputeSubspaceFilterSchedule(const ModelStep& truth, const Eigen::MatrixXd& S0,
                                                     const Subspace& subspace, const SubspaceFilterOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  const BlockOperator applyA = options.apply_A ? options.apply_A : DenseOperator(truth.A);
  CheckScheduleInput(truth, S0, subspace, options, applyA);
  const Eigen::Index N = truth.state_dim(), n = subspace.reduced_dim();
  const MatrixXd& Pi = subspace.projection;
  const MatrixXd Pi_adj = ProjectionAdjoint(subspace);
  const MatrixXd& C = truth.C;

  SubspaceFilterSchedule out;
  Summary& sum = out.summary;
  sum.computation = "subspace filter schedule";
  sum.method = "Algorithm 2.3";
  sum.termination = Termination::kNotConverged;
  MatrixXd S = S0, P = S0, Q = Pi_adj, St = MatrixXd::Zero(n, n);
  RdeCheck rde{S0, MatrixXd()};
  MatrixXd K_prev;
  const int T_max = options.steps >= 0 ? options.steps : options.max_steps;
  if (options.store_schedule) {
    out.gain.emplace_back();
    out.output_map.push_back(Q);
  }
  if (options.store_covariances) {
    out.P.push_back(P);
    if (options.rde_check) {
      out.P_rde.push_back(rde.P_rde);
      out.M.push_back(MatrixXd::Zero(N, N));
    }
  }
  out.pinv_rank.push_back(0);
  MatrixXd K, V, St_pinv;
  int small_changes = 0;
  detail::StagnationDetector floor_detector;
  double rounding_floor = 0.0;
  int k = 0;
  bool failed = false;
  const bool want_P = options.store_covariances || options.rde_check;
  MatrixXd AQ, St_prev, QS, QS_prev;
  for (k = 1; k <= T_max; ++k) {
    // S_k (15), and the anchor A Q_{k-1} (N x n). P~_k = A P_{k-1} A^T + Q (13) with
    // P_{k-1} = S_{k-1} - Q_{k-1} S~_{k-1} Q_{k-1}^T is S_k - (A Q_{k-1}) S~_{k-1} (A Q_{k-1})^T: only
    // its product with C^T is needed, O(N n (n + m)) instead of two N x N applications of A.
    if (!options.stationary_prior) {
      S = Sandwich(applyA, S);
      S += truth.Q;
    }
    AQ = applyA(Q);
    St_prev = St;
    // Gain (14).
    MatrixXd PtCt = S * C.transpose();
    PtCt.noalias() -= AQ * (St * (AQ.transpose() * C.transpose()));
    MatrixXd Sinn = truth.R;
    Sinn.noalias() += C * PtCt;
    Symmetrize(Sinn);
    Eigen::LLT<MatrixXd> llt(Sinn);
    if (llt.info() != Eigen::Success) {
      sum.termination = Termination::kLostDefiniteness;
      sum.message = "C P~_k C^T + R: not positive definite at step " + std::to_string(k);
      failed = true;
      break;
    }
    K = llt.solve(PtCt.transpose()).transpose();  // N x m
    // V_k = A Q_{k-1} S~_{k-1} Q_{k-1}^T A^T Pi^T + K_k (C P~_k C^T + R) K_k^T Pi^T.
    const MatrixXd PiAQ = Pi * AQ;  // n x n
    const MatrixXd PiK = Pi * K;    // n x m
    V.noalias() = AQ * (St * PiAQ.transpose());
    V.noalias() += K * (Sinn * PiK.transpose());
    // RDE (20) needs A Q_{k-1} S~_{k-1} Q_{k-1}^T A^T (= A V_{k-1} S~^+ V_{k-1}^T A^T) before S~ changes.
    MatrixXd X_load;
    if (options.rde_check) {
      X_load.noalias() = AQ * St * AQ.transpose();
      X_load.noalias() += K * PtCt.transpose();  // P~ C^T S^{-1} C P~ = K (P~ C^T)^T
    }
    // S~_k = Pi V_k, Q_k (Remark 2.2), P_k.
    St.noalias() = Pi * V;
    Symmetrize(St);
    const int rank = SymmetricPseudoInverse(St, options.pinv_tolerance, &St_pinv);
    if (rank < 0) {
      sum.termination = Termination::kFailed;
      sum.message = "S~_k: symmetric eigendecomposition failed at step " + std::to_string(k);
      failed = true;
      break;
    }
    out.pinv_rank.push_back(rank);
    MatrixXd Resid = V;
    Resid.noalias() -= Pi_adj * St;  // (I - Pi_s) V_k, as Pi V_k = S~_k
    Q = Pi_adj;
    Q.noalias() += Resid * St_pinv;
    if (want_P) {
      P = S;
      P.noalias() -= (Q * St) * Q.transpose();
      Symmetrize(P);
    }
    if (options.rde_check) {
      rde.Step(truth, applyA, Pi, Q, X_load);
      const double rel = (P - rde.P_rde).norm() / std::max(P.norm(), std::numeric_limits<double>::min());
      out.rde_max_relative_difference = std::max(out.rde_max_relative_difference, rel);
      if (options.store_covariances) {
        out.P_rde.push_back(rde.P_rde);
        out.M.push_back(rde.M_k);
      }
    }
    if (options.store_schedule) {
      out.gain.push_back(K);
      out.output_map.push_back(Q);
    }
    if (options.store_covariances) out.P.push_back(P);

    // Convergence of the gain and of the output map on the range of S~_k: Q_k S~_k (Remark 2.2: x~_k
    // lies in R(S~_k), Q_k is not determined on its complement, and there the pseudoinverse only
    // amplifies round-off). Q_k S~_k = Pi^* S~_k + (I - Pi_s) V_k S~_k^+ S~_k is V_k on R(S~_k).
    QS.noalias() = Q * St;
    if (k > 1) {
      sum.relative_change = std::max(RelativeChange(K, K_prev), RelativeChange(QS, QS_prev));
      small_changes = sum.relative_change <= options.tolerance ? small_changes + 1 : 0;
      const bool at_floor = floor_detector.Observe(sum.relative_change);
      if (small_changes >= options.patience && !sum.ok()) {
        sum.termination = Termination::kConverged;
        out.converged_at = k - options.patience + 1;
      } else if (at_floor && !sum.ok()) {
        // The changes stopped shrinking above the tolerance: the schedule is as settled as this
        // machine's rounding allows (docs/robustness.md, class 15).
        sum.termination = Termination::kConverged;
        out.converged_at = k - detail::StagnationDetector::kWindow + 1;
        rounding_floor = floor_detector.floor();
      }
    }
    K_prev = K;
    QS_prev.swap(QS);
    if (options.progress) options.progress(k, T_max);
    if (options.steps < 0 && sum.ok()) break;
  }
  out.steps = failed ? k - 1 : std::min(k, T_max);
  sum.iterations = out.steps;
  if (!failed && !sum.ok()) {
    sum.message = "the gain and output map did not settle within " + std::to_string(T_max) +
                  " steps (relative change " + FormatNumber(sum.relative_change) + " > tolerance " +
                  FormatNumber(options.tolerance) + ")";
  } else if (sum.ok() && rounding_floor > 0.0) {
    sum.message = "converged at step " + std::to_string(out.converged_at) + " to the rounding floor: the relative " +
                  "change stagnated at " + FormatNumber(rounding_floor) + " (tolerance " +
                  FormatNumber(options.tolerance) + ")";
    sum.SetDetail("rounding_floor", FormatNumber(rounding_floor));
  } else if (sum.ok()) {
    sum.message = "converged at step " + std::to_string(out.converged_at);
  }
  out.K = K;
  out.Q = Q;
  FinishSchedule(S0, S, St, St_prev, AQ, &out);
  out.V = V;
  out.M_final = rde.M_k;
  sum.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

namespace {

LinearFilterStep OnlineStep(const ModelStep& truth, const MatrixXd& Pi, const MatrixXd& K, const MatrixXd& Q_prev,
                            const MatrixXd& Q_now) {
  const MatrixXd AQ = truth.A * Q_prev;
  LinearFilterStep f;
  f.K = Pi * K;
  f.Phi = Pi * AQ;
  f.Phi.noalias() -= f.K * (truth.C * AQ);
  f.O = Q_now;
  return f;
}

void CheckScheduleMatches(const ModelStep& truth, const Subspace& subspace, const SubspaceFilterSchedule& sch) {
  ValidateSubspace(subspace, truth.state_dim());
  if (sch.K.rows() != truth.state_dim() || sch.K.cols() != truth.meas_dim() || sch.Q.rows() != truth.state_dim() ||
      sch.Q.cols() != subspace.reduced_dim()) {
    throw Error("schedule: expected a schedule computed for this model and subspace");
  }
}

}  // namespace

LinearFilter SubspaceFilterAsLinearFilter(const ModelStep& truth, const Subspace& subspace,
                                          const SubspaceFilterSchedule& schedule,
                                          const Eigen::Ref<const Eigen::VectorXd>& m0) {
  CheckScheduleMatches(truth, subspace, schedule);
  const int T = static_cast<int>(schedule.gain.size()) - 1;
  if (T < 1 || schedule.output_map.size() != schedule.gain.size()) {
    throw Error("schedule: expected a stored schedule (options.store_schedule) with at least one step");
  }
  RequireVector("m0", m0, truth.state_dim());
  std::vector<LinearFilterStep> steps;
  steps.reserve(static_cast<size_t>(T));
  for (int k = 1; k <= T; ++k) {
    const auto i = static_cast<size_t>(k);
    steps.push_back(
        OnlineStep(truth, subspace.projection, schedule.gain[i], schedule.output_map[i - 1], schedule.output_map[i]));
  }
  return LinearFilter(std::move(steps), subspace.projection * m0, schedule.output_map[0]);
}

LinearFilter ConvergedSubspaceFilterAsLinearFilter(const ModelStep& truth, const Subspace& subspace,
                                                   const SubspaceFilterSchedule& schedule,
                                                   const Eigen::Ref<const Eigen::VectorXd>& m0) {
  CheckScheduleMatches(truth, subspace, schedule);
  RequireVector("m0", m0, truth.state_dim());
  return LinearFilter(OnlineStep(truth, subspace.projection, schedule.K, schedule.Q, schedule.Q),
                      subspace.projection * m0, schedule.Q);
}

ApproximateSubspaceFilter ComputeApproximateSubspaceFilter(const ModelStep& truth, const Eigen::MatrixXd& S,
                                                           const Subspace& subspace,
                                                           bool measurement_noise_from_residual,
                                                           const BlockOperator& apply_A) {
  const Eigen::Index N = truth.state_dim(), m = truth.meas_dim();
  ValidateStep(truth, N, m, "truth: ");
  RequireShape("S", S, N, N);
  RequirePositiveSemidefinite("S", S);
  ValidateSubspace(subspace, N);
  const MatrixXd& Pi = subspace.projection;
  const MatrixXd Pi_adj = ProjectionAdjoint(subspace);
  const BlockOperator applyA = apply_A ? apply_A : DenseOperator(truth.A);
  const auto t0 = std::chrono::steady_clock::now();
  ApproximateSubspaceFilter out;
  Summary& sum = out.summary;
  sum.computation = "Sec. 6.1 approximate subspace filter";
  sum.method = "reduced model and its DARE";
  const auto finish = [&sum, t0](ApproximateSubspaceFilter& result) {
    sum.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return std::move(result);
  };
  const MatrixXd SPit = S * Pi.transpose();  // N x n
  MatrixXd G = Pi * SPit;                    // Pi S Pi^T
  Symmetrize(G);
  MatrixXd G_pinv;
  if (SymmetricPseudoInverse(G, 1e-12, &G_pinv) < 0) {
    sum.termination = Termination::kFailed;
    sum.message = "Pi S Pi^T: symmetric eigendecomposition failed";
    return finish(out);
  }
  const MatrixXd T = SPit - Pi_adj * G;  // (I - Pi_s) S Pi^T
  out.Q_hat = Pi_adj + T * G_pinv;
  // V^ = (I - Pi_s) S (I - Pi_s)^T - T G^+ T^T as printed is the covariance of x - Q^ Pi x; it is
  // evaluated as (I - Q^ Pi) S (I - Q^ Pi)^T, equal in exact arithmetic and PSD by construction (the
  // printed difference loses definiteness to round-off when the coarse space captures most of S).
  MatrixXd IQPi = -out.Q_hat * Pi;
  IQPi.diagonal().array() += 1.0;
  MatrixXd Y = IQPi * S * IQPi.transpose();
  Symmetrize(Y);
  out.V_hat = Y;
  out.A_r = Pi * applyA(out.Q_hat);
  MatrixXd load = truth.Q + Sandwich(applyA, out.V_hat);
  out.Q_r = Pi * load * Pi.transpose();
  Symmetrize(out.Q_r);
  {
    // V^ is a difference of nearly equal terms when the coarse space captures most of S: clip the
    // round-off negative eigenvalues of Q_r (at most 1e-9 |Q_r|; larger ones are an error).
    Eigen::SelfAdjointEigenSolver<MatrixXd> es(out.Q_r);
    const double lmin = es.eigenvalues().minCoeff(), lmax = es.eigenvalues().cwiseAbs().maxCoeff();
    if (lmin < -1e-9 * lmax) {
      sum.termination = Termination::kLostDefiniteness;
      sum.message =
          "Pi (Q + A V^ A^T) Pi^T is not positive semidefinite (smallest eigenvalue " + FormatNumber(lmin) + ")";
      return finish(out);
    }
    if (lmin < 0) {
      out.Q_r = es.eigenvectors() * es.eigenvalues().cwiseMax(0.0).asDiagonal() * es.eigenvectors().transpose();
      Symmetrize(out.Q_r);
    }
  }
  out.C_r = truth.C * out.Q_hat;
  MatrixXd R = truth.R;
  if (measurement_noise_from_residual) {
    R.noalias() += truth.C * out.V_hat * truth.C.transpose();
    Symmetrize(R);
  }
  out.dare = SolveFilterDare(out.A_r, out.C_r, out.Q_r, R);
  if (!out.dare.summary.ok()) {
    AdoptOutcome(out.dare.summary, &sum);
    sum.message = "reduced " + sum.message;
    return finish(out);
  }
  out.gain = out.dare.filter_gain;
  out.Phi = out.A_r;
  out.Phi.noalias() -= out.gain * (out.C_r * out.A_r);
  sum.termination = Termination::kConverged;
  sum.relative_residual = out.dare.summary.relative_residual;
  return finish(out);
}

LinearFilter ApproximateSubspaceFilterAsLinearFilter(const ApproximateSubspaceFilter& approx,
                                                     const Eigen::Ref<const Eigen::VectorXd>& z0) {
  if (!approx.summary.ok()) {
    throw Error("approx: expected a computed Sec. 6.1 filter, got one that ended " +
                std::string(ToString(approx.summary.termination)) + ": " + approx.summary.message);
  }
  LinearFilterStep f;
  f.Phi = approx.Phi;
  f.K = approx.gain;
  f.O = approx.Q_hat;
  return LinearFilter(std::move(f), z0, approx.Q_hat);
}

}  // namespace kfx
