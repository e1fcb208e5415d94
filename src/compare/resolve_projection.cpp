// The projection family of method specifications (include/kfx/compare.hpp): the reduced-order tau
// filters and the subspace mu estimators of 001 (one-step, two-step data assimilation and forecast), the
// subspace-optimal filter of 000 (Algorithm 2.3) and its Sec. 6.1 approximation. Each becomes the
// LinearFilter of its adapter and runs on data as that recursion.
#include "compare/resolve_internal.hpp"
#include "kfx/damped_wave.hpp"
#include "kfx/error.hpp"
#include "kfx/reduced_order.hpp"
#include "kfx/riccati.hpp"
#include "kfx/subspace_filter.hpp"
#include "kfx/validation.hpp"

namespace kfx::detail {

namespace {

using Eigen::Index;
using Eigen::MatrixXd;

std::string Str(Index v) { return std::to_string(v); }

// The order n_r of a tau / mu spec: order=, or the rows of weight= / columns of basis= (which must agree).
Index Order(const MethodSpec& spec, Index n, const MatrixXd* basis_or_weight, bool weight) {
  Index order = basis_or_weight ? (weight ? basis_or_weight->rows() : basis_or_weight->cols()) : 0;
  if (spec.Has("order")) {
    const Index given = spec.GetPositive("order", 0);
    if (basis_or_weight && given != order) {
      throw Error(Where(spec) + "order=" + Str(given) + " differs from the " +
                  (weight ? "rows of weight" : "columns of basis") + " (" + Str(order) + ")");
    }
    order = given;
  }
  if (order > n) {
    throw Error(Where(spec) + "order " + Str(order) + " is larger than the state dimension " + Str(n));
  }
  return order;
}

MatrixXd ReadShaped(const MethodSpec& spec, const std::string& key, Index rows, const std::string& what) {
  const MatrixXd M = ReadMatrixParameter(spec, key);
  if (M.rows() != rows || M.cols() < 1 || M.cols() > rows) {
    throw Error(Where(spec) + key + ": expected a " + what + " with " + Str(rows) + " rows and 1.." + Str(rows) +
                " columns, got " + ShapeString(M));
  }
  return M;
}

// An orthogonal T whose first n_r columns span `basis` (Householder QR) or the least damped modes of A_1.
MatrixXd ChangeOfBasis(const MethodSpec& spec, const Model& model, const MatrixXd* basis, Index order) {
  const Index n = model.state_dim();
  if (order >= n) {
    throw Error(Where(spec) + "order " + Str(order) + " must be smaller than the state dimension " + Str(n) +
                " (the subspace needs a complement)");
  }
  if (basis) {
    Eigen::HouseholderQR<MatrixXd> qr(*basis);
    const MatrixXd T = qr.householderQ() * MatrixXd::Identity(n, n);
    Eigen::ColPivHouseholderQR<MatrixXd> rank(*basis);
    if (rank.rank() < order) throw Error(Where(spec) + "basis: expected full column rank " + Str(order));
    return T;
  }
  try {
    return LeastDampedSubspace(model.step(1)->A, order).T;
  } catch (const Error& e) {
    throw Error(Where(spec) + "modes=least-damped: " + e.what());
  }
}

TwoStepOutput Output(const std::string& step) {
  return step == "two-forecast" ? TwoStepOutput::kForecast : TwoStepOutput::kDataAssimilation;
}

ResolvedMethod Tau(const MethodSpec& spec, const Model& model, int T) {
  const Index n = model.state_dim();
  MatrixXd L;
  if (spec.Has("weight")) {
    L = ReadMatrixParameter(spec, "weight");
    if (L.cols() != n || L.rows() < 1 || L.rows() > n) {
      throw Error(Where(spec) + "weight: expected an L with " + Str(n) + " columns and 1.." + Str(n) + " rows, got " +
                  ShapeString(L));
    }
    Order(spec, n, &L, true);
  } else if (spec.Has("basis")) {
    const MatrixXd V = ReadShaped(spec, "basis", n, "basis");
    Order(spec, n, &V, false);
    L = Eigen::HouseholderQR<MatrixXd>(V).householderQ() * MatrixXd::Identity(n, V.cols());
    L.transposeInPlace();
  } else {
    const Index order = Order(spec, n, nullptr, false);
    L = order == n ? MatrixXd::Identity(n, n)
                   : MatrixXd(ChangeOfBasis(spec, model, nullptr, order).leftCols(order).transpose());
  }
  const WeightSchedule W(L);
  ReducedOrderOptions ro;
  ro.steps = T;
  ResolvedMethod r;
  const std::string step = spec.Get("step", "one");
  if (step == "one") {
    const ReducedOrderOneStep s = ComputeReducedOrderOneStep(model, W, ro);
    r.filter = std::make_shared<LinearFilter>(ReducedOrderOneStepAsLinearFilter(s, W));
  } else {
    const ReducedOrderTwoStep s = ComputeReducedOrderTwoStep(model, W, ro);
    r.filter = std::make_shared<LinearFilter>(ReducedOrderTwoStepAsLinearFilter(s, W, Output(step)));
  }
  r.description = "reduced-order filter (tau), order " + Str(L.rows()) + ", " + step + "-step";
  if (step != "one") r.description = "reduced-order filter (tau), order " + Str(L.rows()) + ", " + step;
  r.memory_bytes = LinearFilterBytes(*r.filter);
  return r;
}

ResolvedMethod Mu(const MethodSpec& spec, const Model& model, int T) {
  const Index n = model.state_dim();
  MatrixXd V;
  if (spec.Has("basis")) V = ReadShaped(spec, "basis", n, "basis");
  const Index order = Order(spec, n, spec.Has("basis") ? &V : nullptr, false);
  const MatrixXd Tb = ChangeOfBasis(spec, model, spec.Has("basis") ? &V : nullptr, order);
  // The estimated quantity: the subspace coordinates V_r^T x (001 Sec. IV weights x' = T^T x).
  const WeightSchedule L(MatrixXd(Tb.leftCols(order).transpose()));
  ReducedOrderOptions ro;
  ro.steps = T;
  ResolvedMethod r;
  const std::string step = spec.Get("step", "one");
  if (step == "one") {
    const SubspaceOneStep s = ComputeSubspaceOneStep(model, Tb, order, L, ro);
    r.filter = std::make_shared<LinearFilter>(SubspaceOneStepAsLinearFilter(s, Tb, order));
  } else {
    const SubspaceTwoStep s = ComputeSubspaceTwoStep(model, Tb, order, L, ro);
    r.filter = std::make_shared<LinearFilter>(SubspaceTwoStepAsLinearFilter(s, Tb, order, Output(step)));
  }
  r.description = "subspace estimator (mu), order " + Str(order) + ", " + (step == "one" ? "one-step" : step);
  r.memory_bytes = LinearFilterBytes(*r.filter);
  return r;
}

MatrixXd BlockDiag2(const MatrixXd& a, const MatrixXd& b) {
  MatrixXd out = MatrixXd::Zero(a.rows() + b.rows(), a.cols() + b.cols());
  out.topLeftCorner(a.rows(), a.cols()) = a;
  out.bottomRightCorner(b.rows(), b.cols()) = b;
  return out;
}

// mesh=N_c: the coarse space of nested P1 meshes on [0, 1] (the damped-wave builder of 000): the true
// state is x = (z, v) on the N_f = n / 2 interior fine nodes; the basis blkdiag(E, E) with E the
// coarse-to-fine prolongation, the Gram matrix blkdiag(stiffness, mass) of the fine mesh.
void MeshSubspace(const MethodSpec& spec, Index n, MatrixXd* E, MatrixXd* W) {
  const long coarse = spec.GetPositive("mesh", 0);
  if (n % 2 != 0) {
    throw Error(Where(spec) + "mesh: expected a state x = (z, v) on the fine mesh's nodes (n even), got n = " + Str(n));
  }
  const long fine = static_cast<long>(n / 2);
  if (coarse >= fine || (fine + 1) % (coarse + 1) != 0) {
    throw Error(
        Where(spec) + "mesh=" + std::to_string(coarse) + ": the meshes are not nested: the fine mesh has " +
        std::to_string(fine) + " interior nodes (n = " + Str(n) + "), and fine + 1 = " + std::to_string(fine + 1) +
        " must be a multiple of mesh + 1 = " + std::to_string(coarse + 1) + " with mesh < " + std::to_string(fine));
  }
  const MatrixXd P = P1Prolongation(static_cast<int>(fine), static_cast<int>(coarse));
  *E = BlockDiag2(P, P);
  *W = BlockDiag2(P1Stiffness(static_cast<int>(fine)), P1Mass(static_cast<int>(fine)));
}

Subspace ReadSubspace(const MethodSpec& spec, Index n) {
  MatrixXd E, W;
  if (spec.Has("mesh")) {
    MeshSubspace(spec, n, &E, &W);
  } else {
    E = ReadShaped(spec, "basis", n, "basis");
  }
  if (spec.Has("gram")) W = ReadMatrixParameter(spec, "gram");
  if (spec.Has("gram") && (W.rows() != n || W.cols() != n)) {
    throw Error(Where(spec) + "gram: expected a " + ShapeString(n, n) + " matrix, got " + ShapeString(W));
  }
  try {
    return SubspaceFromBasis(E, W);
  } catch (const Error& e) {
    throw Error(Where(spec) + e.what());
  }
}

// 000 Algorithm 2.3 from S_0 = P0: the schedule over T steps, or its converged filter.
ResolvedMethod SubspaceOptimal(const MethodSpec& spec, const Model& model, const MethodOptions& options) {
  RequireTimeInvariant(spec, model);
  const StepPtr step_ptr = model.step(1);
  const ModelStep& s = *step_ptr;
  const Subspace sub = ReadSubspace(spec, model.state_dim());
  const bool converged = spec.Get("gain", options.stationary ? "converged" : "schedule") == "converged";
  SubspaceFilterOptions so;
  so.steps = converged ? -1 : options.steps;
  so.store_schedule = !converged;
  const SubspaceFilterSchedule sch = ComputeSubspaceFilterSchedule(s, model.P0(), sub, so);
  const bool usable = sch.summary.ok() || (!converged && sch.summary.termination == Termination::kNotConverged);
  if (!usable) throw NumericalError(Where(spec) + "schedule: " + sch.summary.BriefReport());
  ResolvedMethod r;
  r.filter = std::make_shared<LinearFilter>(converged ? ConvergedSubspaceFilterAsLinearFilter(s, sub, sch, model.m0())
                                                      : SubspaceFilterAsLinearFilter(s, sub, sch, model.m0()));
  (converged ? r.claimed_stationary_cov : r.claimed_cov) = sch.P_final;
  r.description = "subspace-optimal filter (000 Alg. 2.3), " + Str(sub.reduced_dim()) + "-dim subspace, " +
                  (converged ? "converged gain" : "gain schedule");
  r.memory_bytes = LinearFilterBytes(*r.filter);
  return r;
}

// 000 Sec. 6.1: the Kalman filter of the approximate reduced model from the stationary state covariance.
ResolvedMethod Approximate61(const MethodSpec& spec, const Model& model) {
  RequireTimeInvariant(spec, model);
  const StepPtr step_ptr = model.step(1);
  const ModelStep& s = *step_ptr;
  const Subspace sub = ReadSubspace(spec, model.state_dim());
  const LyapunovSolution lyap = SolveDiscreteLyapunov(s.A, s.Q);
  if (!lyap.summary.ok()) {
    throw NumericalError(Where(spec) + "stationary state covariance (needs a stable A): " + lyap.summary.BriefReport());
  }
  const MatrixXd S = 0.5 * (lyap.X + lyap.X.transpose());
  const ApproximateSubspaceFilter ap = ComputeApproximateSubspaceFilter(s, S, sub);
  if (!ap.summary.ok()) throw NumericalError(Where(spec) + ap.summary.BriefReport());
  ResolvedMethod r;
  r.filter = std::make_shared<LinearFilter>(ApproximateSubspaceFilterAsLinearFilter(ap, sub.projection * model.m0()));
  // What the approximate model claims: the residual V^ plus the reduced filter's error lifted by Q^.
  r.claimed_stationary_cov = ap.V_hat + ap.Q_hat * ap.dare.P_filt * ap.Q_hat.transpose();
  r.description = "Sec. 6.1 approximation of the subspace-optimal filter, " + Str(sub.reduced_dim()) + "-dim subspace";
  r.memory_bytes = LinearFilterBytes(*r.filter);
  return r;
}

}  // namespace

ResolvedMethod ResolveProjection(const MethodSpec& spec, const ComparisonModel& truth, const MethodOptions& options) {
  const Model& model = truth.model;
  if (spec.name == "tau") return Tau(spec, model, options.steps);
  if (spec.name == "mu") return Mu(spec, model, options.steps);
  if (spec.name == "subspace") return SubspaceOptimal(spec, model, options);
  return Approximate61(spec, model);
}

}  // namespace kfx::detail
