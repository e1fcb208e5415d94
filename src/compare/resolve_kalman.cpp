// The Kalman family of method specifications (include/kfx/compare.hpp): kalman, steady, design (002),
// coarse (a filter designed on a reduced model, its estimate lifted), blockdiag and banded (004). Each
// becomes the LinearFilter of its adapter; the Kalman filter and the coupled filters run on data in their
// own implementations (RunFilter, RunCoupledFilter).
#include "compare/resolve_internal.hpp"
#include "kfx/error.hpp"
#include "kfx/io.hpp"
#include "kfx/kalman_filter.hpp"
#include "kfx/riccati.hpp"
#include "kfx/validation.hpp"

namespace kfx::detail {

namespace {

using Eigen::MatrixXd;

DareSolution SteadyState(const MethodSpec& spec, const ModelStep& s, const std::string& what) {
  DareSolution dare = SteadyStateDare(s);
  if (!dare.summary.ok()) throw NumericalError(Where(spec) + what + " DARE: " + dare.summary.BriefReport());
  return dare;
}

// RunFilter's memory: x, P and the model step (A, Q, C, R).
double KalmanBytes(Eigen::Index n, Eigen::Index m) { return 8.0 * static_cast<double>(n + 3 * n * n + m * n + m * m); }

ResolvedMethod KalmanWithSchedule(const MethodSpec& spec, const Model& model, const KalmanFilterOptions& form, int T,
                                  std::string description) {
  ResolvedMethod r;
  KalmanScheduleOptions so;
  so.steps = T;
  so.filter = form;
  const KalmanSchedule sch = ComputeKalmanSchedule(model, so);
  r.filter = std::make_shared<LinearFilter>(KalmanAsLinearFilter(model, sch));
  r.claimed_cov = sch.P_filt.back();
  r.run = [model, form](const TimeSeries& y) {
    FilterRunOptions o;
    o.filter = form;
    o.store_covariances = false;
    return RunFilter(model, y, o).x_filt;
  };
  r.online = "RunFilter";
  r.memory_bytes = KalmanBytes(model.state_dim(), model.meas_dim());
  r.description = std::move(description);
  (void)spec;
  return r;
}

ResolvedMethod SteadyGain(const MethodSpec& spec, const Model& design, const std::string& what,
                          std::string description) {
  RequireTimeInvariant(spec, design);
  const StepPtr step_ptr = design.step(1);
  const ModelStep& s = *step_ptr;
  const DareSolution dare = SteadyState(spec, s, what);
  ResolvedMethod r;
  r.filter = std::make_shared<LinearFilter>(ConstantGainAsLinearFilter(s, dare.filter_gain, design.m0()));
  r.claimed_cov = r.claimed_stationary_cov = dare.P_filt;
  r.online = "RunLinearFilter";
  r.memory_bytes = LinearFilterBytes(*r.filter);
  r.description = std::move(description);
  return r;
}

Model LoadDesign(const MethodSpec& spec, const std::string& key, const Model& truth, bool same_state) {
  Model design = [&] {
    try {
      return LoadModel(spec.Get(key));
    } catch (const Error& e) {
      throw Error(Where(spec) + key + ": " + e.what());
    }
  }();
  if (design.meas_dim() != truth.meas_dim() || (same_state && design.state_dim() != truth.state_dim())) {
    throw Error(Where(spec) + key + ": expected a model with " +
                (same_state ? "n = " + std::to_string(truth.state_dim()) + ", " : std::string()) +
                "m = " + std::to_string(truth.meas_dim()) + " (as the true model), got n = " +
                std::to_string(design.state_dim()) + ", m = " + std::to_string(design.meas_dim()));
  }
  return design;
}

// The steady-state Kalman filter of a reduced model (n_c states), its estimate lifted by E (n x n_c).
ResolvedMethod Coarse(const MethodSpec& spec, const Model& truth) {
  const Model coarse = LoadDesign(spec, "model", truth, false);
  const MatrixXd E = ReadMatrixParameter(spec, "prolongation");
  if (E.rows() != truth.state_dim() || E.cols() != coarse.state_dim()) {
    throw Error(Where(spec) + "prolongation: expected a " + ShapeString(truth.state_dim(), coarse.state_dim()) +
                " matrix (true state x reduced state), got " + ShapeString(E));
  }
  ResolvedMethod r = SteadyGain(spec, coarse, "reduced model's",
                                "steady-state Kalman filter of the reduced model (" +
                                    std::to_string(coarse.state_dim()) + " states), lifted by the prolongation");
  LinearFilterStep step = *r.filter->step(1);
  step.O = E;
  r.filter = std::make_shared<LinearFilter>(std::move(step), coarse.m0(), E);
  r.claimed_cov = r.claimed_stationary_cov = E * r.claimed_cov * E.transpose();
  r.memory_bytes = LinearFilterBytes(*r.filter);
  return r;
}

ResolvedMethod Coupled(const MethodSpec& spec, const ComparisonModel& truth, int T) {
  if (!truth.coupled) {
    throw Error(Where(spec) + spec.name +
                " needs a coupled model (a \"kfx-coupled-model\" file, docs/formats.md), "
                "got a plain model");
  }
  const CoupledSystem system = *truth.coupled;
  const CoupledFilterKind kind = spec.name == "banded" ? CoupledFilterKind::kBanded : CoupledFilterKind::kBlockDiagonal;
  CoupledFilterOptions co;
  co.steps = T;
  ResolvedMethod r;
  r.filter = std::make_shared<LinearFilter>(CoupledFilterAsLinearFilter(system, kind, co));
  // The filter's own covariance at T does not depend on the data: run it on zero measurements.
  CoupledFilter own(kind, system.m0(), system.P0_blocks());
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(system.meas_dim());
  for (int k = 1; k <= T; ++k) own.Step(*system.step(k), zero);
  r.claimed_cov = own.P().rows() == own.P().cols() && own.P().rows() == system.state_dim()
                      ? own.P()
                      : BlockDiagonalToDense(own.P(), system.c());
  r.run = [system, kind](const TimeSeries& y) { return RunCoupledFilter(system, kind, y).x_filt; };
  r.online = "RunCoupledFilter";
  const double n = static_cast<double>(system.n()), c = static_cast<double>(system.c());
  const double d = static_cast<double>(system.d()), rr = static_cast<double>(system.r());
  // Packed covariance and gain blocks, the coupling terms, the state.
  r.memory_bytes = 8.0 * (n * c * (2 * c + d + 2 * rr) + rr * rr + n * c);
  r.description =
      std::string(ToString(kind)) + " filter of the coupled model (" + std::to_string(system.n()) + " subsystems)";
  return r;
}

}  // namespace

ResolvedMethod ResolveKalmanFamily(const MethodSpec& spec, const ComparisonModel& truth, const MethodOptions& options) {
  const Model& model = truth.model;
  const int T = options.steps;
  const std::string& n = spec.name;
  if (n == "kalman") {
    const std::string form = spec.Get("form", "joseph");
    const KalmanFilterOptions fo = ParseKalmanForm(Where(spec) + "form", form);
    if (options.stationary && model.time_invariant()) {
      ResolvedMethod r = SteadyGain(spec, model, "filter", "Kalman filter, stationary limit (steady state)");
      return r;
    }
    return KalmanWithSchedule(spec, model, fo, T, "Kalman filter (" + form + " form)");
  }
  if (n == "steady") return SteadyGain(spec, model, "filter", "steady-state Kalman filter");
  if (n == "design") {
    const Model design = LoadDesign(spec, "model", model, true);
    if (spec.Get("gain", "steady") == "schedule") {
      return KalmanWithSchedule(spec, design, KalmanFilterOptions(), T,
                                "Kalman filter designed on " + spec.Get("model"));
    }
    return SteadyGain(spec, design, "design model's", "steady-state filter designed on " + spec.Get("model"));
  }
  if (n == "coarse") return Coarse(spec, model);
  if (n == "blockdiag" || n == "banded") return Coupled(spec, truth, T);
  throw Error(Where(spec) + "unknown method '" + n + "'");
}

}  // namespace kfx::detail
