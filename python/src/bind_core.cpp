// kfx._core: models, simulation, the Kalman filter and smoother (with a FilterPy-familiar class),
// the Riccati/Lyapunov solvers, linear filters and the exact-performance engine, `reproduce`.
// The docstrings summarize the C++ doc comments of include/kfx/*.hpp (the reference).
#include <cstdint>
#include <sstream>

#include "bindings.hpp"
#include "kfx/discretize.hpp"
#include "kfx/enum_text.hpp"
#include "kfx/error.hpp"
#include "kfx/kalman_filter.hpp"
#include "kfx/linear_filter.hpp"
#include "kfx/model.hpp"
#include "kfx/performance.hpp"
#include "kfx/reproduce.hpp"
#include "kfx/riccati.hpp"
#include "kfx/simulation.hpp"
#include "kfx/summary.hpp"
#include "kfx/validation.hpp"

namespace kfx::python {

py::array_t<double> Stack(const std::vector<Eigen::MatrixXd>& matrices, size_t begin) {
  const size_t K = matrices.size() > begin ? matrices.size() - begin : 0;
  const Eigen::Index r = K ? matrices[begin].rows() : 0, c = K ? matrices[begin].cols() : 0;
  py::array_t<double> out({static_cast<py::ssize_t>(K), static_cast<py::ssize_t>(r), static_cast<py::ssize_t>(c)});
  auto a = out.mutable_unchecked<3>();
  for (size_t k = 0; k < K; ++k) {
    const Eigen::MatrixXd& M = matrices[begin + k];
    if (M.rows() != r || M.cols() != c) throw Error("internal: matrices of different shapes in a stack");
    for (Eigen::Index i = 0; i < r; ++i)
      for (Eigen::Index j = 0; j < c; ++j) a(static_cast<py::ssize_t>(k), i, j) = M(i, j);
  }
  return out;
}

std::vector<Eigen::MatrixXd> Unstack(const py::array& stack, const std::string& name) {
  auto arr = py::array_t<double, py::array::forcecast>::ensure(stack);
  if (!arr || arr.ndim() != 3) throw Error(name + ": expected a (K, rows, cols) float array");
  auto a = arr.unchecked<3>();
  std::vector<Eigen::MatrixXd> out(static_cast<size_t>(a.shape(0)), Eigen::MatrixXd(a.shape(1), a.shape(2)));
  for (py::ssize_t k = 0; k < a.shape(0); ++k)
    for (py::ssize_t i = 0; i < a.shape(1); ++i)
      for (py::ssize_t j = 0; j < a.shape(2); ++j) out[static_cast<size_t>(k)](i, j) = a(k, i, j);
  return out;
}

std::vector<Eigen::MatrixXd> MatrixList(const py::object& seq, const std::string& name) {
  if (py::isinstance<py::array>(seq) && seq.cast<py::array>().ndim() == 3) return Unstack(seq, name);
  std::vector<Eigen::MatrixXd> out;
  size_t i = 0;
  for (const auto& item : seq) {
    try {
      out.push_back(item.cast<Eigen::MatrixXd>());
    } catch (const py::cast_error&) {
      throw Error(name + "[" + std::to_string(i) + "]: expected a 2-D float array");
    }
    ++i;
  }
  return out;
}

namespace {

// ---- FilterPy-style Kalman filter ------------------------------------------------------------------

// Holds the step (F, H, Q, R), the estimate (x, P) and what FilterPy users read after each call (K, y,
// S, log_likelihood, x_prior, ...). The arithmetic is kfx::Predict / kfx::Update.
class PyKalmanFilter {
 public:
  PyKalmanFilter(Eigen::Index dim_x, Eigen::Index dim_z) {
    if (dim_x < 1) throw Error("dim_x: expected >= 1, got " + std::to_string(dim_x));
    if (dim_z < 1) throw Error("dim_z: expected >= 1, got " + std::to_string(dim_z));
    n_ = dim_x;
    m_ = dim_z;
    step_ = MakeStep(Eigen::MatrixXd::Identity(n_, n_), Eigen::MatrixXd::Zero(m_, n_),
                     Eigen::MatrixXd::Identity(n_, n_), Eigen::MatrixXd::Identity(m_, m_));
    est_ = Estimate{Eigen::VectorXd::Zero(n_), Eigen::MatrixXd::Identity(n_, n_)};
    prior_ = post_ = est_;
    K_ = Eigen::MatrixXd::Zero(n_, m_);
    y_ = Eigen::VectorXd::Zero(m_);
    S_ = Eigen::MatrixXd::Zero(m_, m_);
  }
  explicit PyKalmanFilter(const Model& model) : PyKalmanFilter(model.state_dim(), model.meas_dim()) {
    if (!model.time_invariant()) throw Error("model: expected a time-invariant model (use kfx.run_filter)");
    const StepPtr s = model.step(1);
    step_ = MakeStep(s->A, s->C, s->Q, s->R);
    est_ = Estimate{model.m0(), model.P0()};
    prior_ = post_ = est_;
  }

  Eigen::Index dim_x() const { return n_; }
  Eigen::Index dim_z() const { return m_; }
  // Copies, never views: the next predict/update replaces the buffers.
  Eigen::VectorXd x() const { return est_.x; }
  Eigen::MatrixXd P() const { return est_.P; }
  Eigen::MatrixXd F() const { return step_.A; }
  Eigen::MatrixXd H() const { return step_.C; }
  Eigen::MatrixXd Q() const { return step_.Q; }
  Eigen::MatrixXd R() const { return step_.R; }

  void set_x(const Eigen::MatrixXd& x) {
    if (!((x.cols() == 1 && x.rows() == n_) || (x.rows() == 1 && x.cols() == n_)))
      throw Error("x: expected shape (" + std::to_string(n_) + ",) or (" + std::to_string(n_) + ", 1), got " +
                  ShapeString(x));
    RequireFinite("x", x);
    est_.x = x.reshaped();
  }
  void set_P(const Eigen::MatrixXd& P) {
    RequireShape("P", P, n_, n_);
    RequirePositiveSemidefinite("P", P);
    est_.P = P;
  }
  void set_F(const Eigen::MatrixXd& F) {
    RequireShape("F", F, n_, n_);
    RequireFinite("F", F);
    step_.A = F;
  }
  void set_H(const Eigen::MatrixXd& H) {
    RequireShape("H", H, m_, n_);
    RequireFinite("H", H);
    step_.C = H;
  }
  void set_Q(const Eigen::MatrixXd& Q) {
    RequireShape("Q", Q, n_, n_);
    RequirePositiveSemidefinite("Q", Q);
    step_.Q = Q;
  }
  void set_R(const Eigen::MatrixXd& R) {
    RequireShape("R", R, m_, m_);
    RequirePositiveDefinite("R", R);
    step_.R = R;
  }

  void predict() {
    est_ = Predict(est_, step_, options_);
    prior_ = est_;
  }
  void update(const Eigen::Ref<const Eigen::VectorXd>& z) {
    UpdateResult r = Update(est_, step_, z, options_);
    const bool all = static_cast<Eigen::Index>(r.observed.size()) == m_;
    if (all) {
      y_ = std::move(r.innovation);
      K_ = std::move(r.gain);
      S_ = std::move(r.innovation_cov);
    } else {  // scatter the observed entries back (NaN / zero elsewhere)
      y_.setConstant(m_, std::numeric_limits<double>::quiet_NaN());
      K_.setZero(n_, m_);
      S_.setConstant(m_, m_, std::numeric_limits<double>::quiet_NaN());
      for (size_t i = 0; i < r.observed.size(); ++i) {
        y_(r.observed[i]) = r.innovation(static_cast<Eigen::Index>(i));
        K_.col(r.observed[i]) = r.gain.col(static_cast<Eigen::Index>(i));
        for (size_t j = 0; j < r.observed.size(); ++j)
          S_(r.observed[i], r.observed[j]) =
              r.innovation_cov(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j));
      }
    }
    log_likelihood_ = r.log_likelihood;
    est_ = std::move(r.estimate);
    post_ = est_;
  }

  Model AsModel() const { return Model(step_, est_.x, est_.P); }

  // FilterPy's tuple (means, covariances, means_p, covariances_p), time-major, k = 1..T.
  py::tuple batch_filter(const TimeSeries& zs, bool update_state) {
    if (zs.cols() != m_)
      throw Error("zs: expected shape (T, " + std::to_string(m_) + "), got " + ShapeString(zs.rows(), zs.cols()));
    FilterRunOptions opt;
    opt.filter = options_;
    FilterRun run = RunFilter(AsModel(), zs, opt);
    const Eigen::Index T = zs.rows();
    TimeSeries means = run.x_filt.bottomRows(T), means_p = run.x_pred.bottomRows(T);
    if (update_state && T > 0) {
      est_ = Estimate{run.x_filt.row(T).transpose(), run.P_filt.back()};
      prior_ = Estimate{run.x_pred.row(T).transpose(), run.P_pred.back()};
      post_ = est_;
      log_likelihood_ = run.log_likelihood_terms(T - 1);
    }
    return py::make_tuple(means, Stack(run.P_filt, 1), means_p, Stack(run.P_pred, 1));
  }

  // FilterPy's rts_smoother(Xs, Ps): (x, P, K, Pp) over the T filtered estimates given.
  py::tuple rts_smoother(const TimeSeries& Xs, const py::array& Ps_array) const {
    const Eigen::Index T = Xs.rows();
    if (Xs.cols() != n_)
      throw Error("Xs: expected shape (T, " + std::to_string(n_) + "), got " + ShapeString(T, Xs.cols()));
    std::vector<Eigen::MatrixXd> Ps = Unstack(Ps_array, "Ps");
    if (static_cast<Eigen::Index>(Ps.size()) != T || (T > 0 && (Ps[0].rows() != n_ || Ps[0].cols() != n_)))
      throw Error("Ps: expected shape (" + std::to_string(T) + ", " + std::to_string(n_) + ", " + std::to_string(n_) +
                  ")");
    if (T == 0) throw Error("Xs: expected at least one estimate");
    for (Eigen::Index k = 0; k < T; ++k) RequirePositiveSemidefinite("Ps[" + std::to_string(k) + "]", Ps[k]);
    RequireFinite("Xs", Xs);
    // A filter run whose prior is the first estimate: x_pred, P_pred recomputed from F, Q.
    FilterRun run;
    run.x_filt = Xs;
    run.x_pred = Xs;
    run.P_filt = Ps;
    run.P_pred.resize(static_cast<size_t>(T));
    run.P_pred[0] = Ps[0];
    for (Eigen::Index k = 1; k < T; ++k) {
      run.x_pred.row(k) = (step_.A * Xs.row(k - 1).transpose()).transpose();
      run.P_pred[k] = step_.A * Ps[k - 1] * step_.A.transpose() + step_.Q;
    }
    const Model model(step_, Xs.row(0).transpose(), Ps[0]);
    SmootherRun sm = RtsSmooth(model, run);
    // Smoother gains G_k = P_{k|k} F^T P_{k+1|k}^{-1} (FilterPy's K), zero for the last estimate.
    std::vector<Eigen::MatrixXd> G(static_cast<size_t>(T), Eigen::MatrixXd::Zero(n_, n_));
    for (Eigen::Index k = 0; k + 1 < T; ++k)
      G[k] = run.P_pred[k + 1].completeOrthogonalDecomposition().solve(step_.A * Ps[k]).transpose();
    std::vector<Eigen::MatrixXd> Pp(static_cast<size_t>(T));
    for (Eigen::Index k = 0; k < T; ++k) Pp[k] = step_.A * Ps[k] * step_.A.transpose() + step_.Q;
    return py::make_tuple(sm.x, Stack(sm.P), Stack(G), Stack(Pp));
  }

  KalmanFilterOptions options_;
  Eigen::Index n_ = 0, m_ = 0;
  ModelStep step_;
  Estimate est_, prior_, post_;
  Eigen::MatrixXd K_, S_;
  Eigen::VectorXd y_;
  double log_likelihood_ = 0.0;
};

CovarianceUpdateForm ParseUpdateForm(const std::string& s) { return ParseEnum<CovarianceUpdateForm>("update_form", s); }

py::dict ItemToDict(const std::string& paper, const ReproduceItem& it) {
  py::dict d;
  d["paper"] = paper;
  d["key"] = it.key;
  d["description"] = it.description;
  d["published"] = it.published ? py::object(py::float_(*it.published)) : py::object(py::none());
  d["value"] = it.value;
  const auto rel = it.rel_diff();
  d["rel_diff"] = rel ? py::object(py::float_(*rel)) : py::object(py::none());
  d["tolerance"] = it.tolerance;
  d["status"] = it.status();
  d["note"] = it.note;
  return d;
}

#define KFX_RO(cls, field, doc) def_readonly(#field, &cls::field, doc)

void BindSummary(py::module_& m) {
  py::class_<Summary>(m, "Summary",
                      "How a solver or long computation ended: the one outcome shape of kfx. Numerical outcomes "
                      "(no convergence, a singular equation, lost definiteness, an unstable system) are reported "
                      "here, never raised; invalid input raises kfx.Error.")
      .def_readonly("computation", &Summary::computation, "what was computed, e.g. 'filter DARE'")
      .def_property_readonly(
          "termination", [](const Summary& s) { return std::string(ToString(s.termination)); },
          "'converged', 'not_converged', 'not_stabilizing', 'not_detectable', 'not_stabilizable', 'unstable', "
          "'singular', 'lost_definiteness', 'undecided' or 'failed'")
      .def_property_readonly("ok", &Summary::ok, "termination == 'converged'")
      .def_readonly("message", &Summary::message)
      .def_readonly("method", &Summary::method, "the algorithm that produced the result")
      .def_readonly("iterations", &Summary::iterations)
      .def_readonly("relative_residual", &Summary::relative_residual, "NaN when not computed")
      .def_readonly("relative_change", &Summary::relative_change, "an iteration's last relative change (NaN: none)")
      .def_readonly("seconds", &Summary::seconds)
      .def_property_readonly(
          "details",
          [](const Summary& s) {
            py::dict d;
            for (const auto& [key, value] : s.details) d[py::str(key)] = value;
            return d;
          },
          "further named facts of the computation (as strings)")
      .def("brief_report", &Summary::BriefReport)
      .def("full_report", &Summary::FullReport)
      .def("__repr__", &Summary::BriefReport);
}

void BindCore(py::module_& m) {
  // ---- errors ----
  py::register_exception<Error>(m, "Error", PyExc_ValueError);
  py::register_exception<NumericalError>(m, "NumericalError", PyExc_ArithmeticError);
  BindSummary(m);

  // ---- models ----
  py::class_<ModelStep>(m, "ModelStep",
                        "The matrices of one step: x_k = A x_{k-1} + w_k, w_k ~ N(0, Q) (or w_k = B u_k, u_k ~ "
                        "N(0, U), Q = B U B^T); y_k = C x_k + v_k, v_k ~ N(0, R).")
      .def(py::init([](Eigen::MatrixXd A, Eigen::MatrixXd C, std::optional<Eigen::MatrixXd> Q, Eigen::MatrixXd R,
                       std::optional<Eigen::MatrixXd> B, std::optional<Eigen::MatrixXd> U) {
             if (B || U) {
               if (!B || !U) throw Error("B, U: expected both (noise input w = B u, u ~ N(0, U)) or neither");
               if (Q) throw Error("Q: expected None when B and U are given (Q = B U B^T)");
               ModelStep s =
                   MakeStepWithNoiseInput(std::move(A), std::move(*B), std::move(*U), std::move(C), std::move(R));
               ValidateStep(s, s.A.rows(), s.C.rows());
               return s;
             }
             if (!Q) throw Error("Q: expected the process-noise covariance (or B and U)");
             ModelStep s = MakeStep(std::move(A), std::move(C), std::move(*Q), std::move(R));
             ValidateStep(s, s.A.rows(), s.C.rows());
             return s;
           }),
           py::arg("A"), py::arg("C"), py::arg("Q") = py::none(), py::arg("R"), py::arg("B") = py::none(),
           py::arg("U") = py::none(), "Validated step (raises kfx.Error naming the matrix at fault).")
      .def_readonly("A", &ModelStep::A)
      .def_readonly("C", &ModelStep::C)
      .def_readonly("Q", &ModelStep::Q)
      .def_readonly("R", &ModelStep::R)
      .def_readonly("B", &ModelStep::B)
      .def_readonly("U", &ModelStep::U)
      .def_property_readonly("state_dim", &ModelStep::state_dim)
      .def_property_readonly("meas_dim", &ModelStep::meas_dim);

  py::class_<Model>(m, "Model",
                    "A validated discrete-time model x_k = A_k x_{k-1} + w_k, y_k = C_k x_k + v_k, x_0 ~ N(m0, P0); "
                    "the first measurement is y_1. Time-invariant (one ModelStep) or time-varying (a list).")
      .def(py::init([](const Eigen::MatrixXd& A, const Eigen::MatrixXd& C, std::optional<Eigen::MatrixXd> Q,
                       const Eigen::MatrixXd& R, Eigen::VectorXd m0, Eigen::MatrixXd P0,
                       std::optional<Eigen::MatrixXd> B, std::optional<Eigen::MatrixXd> U) {
             ModelStep s;
             if (B || U) {
               if (!B || !U) throw Error("B, U: expected both (noise input w = B u, u ~ N(0, U)) or neither");
               if (Q) throw Error("Q: expected None when B and U are given (Q = B U B^T)");
               s = MakeStepWithNoiseInput(A, *B, *U, C, R);
             } else {
               if (!Q) throw Error("Q: expected the process-noise covariance (or B and U)");
               s = MakeStep(A, C, *Q, R);
             }
             return Model(std::move(s), std::move(m0), std::move(P0));
           }),
           py::arg("A"), py::arg("C"), py::arg("Q") = py::none(), py::arg("R"), py::arg("m0"), py::arg("P0"),
           py::arg("B") = py::none(), py::arg("U") = py::none(), "Time-invariant model.")
      .def(py::init<ModelStep, Eigen::VectorXd, Eigen::MatrixXd>(), py::arg("step"), py::arg("m0"), py::arg("P0"))
      .def(py::init<std::vector<ModelStep>, Eigen::VectorXd, Eigen::MatrixXd>(), py::arg("steps"), py::arg("m0"),
           py::arg("P0"), "Time-varying model over k = 1..len(steps) (steps[k-1] is step k).")
      .def_property_readonly("state_dim", &Model::state_dim)
      .def_property_readonly("meas_dim", &Model::meas_dim)
      .def_property_readonly("time_invariant", &Model::time_invariant)
      .def_property_readonly("horizon", &Model::horizon, "Steps defined (-1: unbounded).")
      .def_property_readonly("m0", &Model::m0)
      .def_property_readonly("P0", &Model::P0)
      .def(
          "step", [](const Model& mo, int k) { return *mo.step(k); }, py::arg("k"), "The matrices of step k >= 1.")
      .def("with_prior", &Model::WithPrior, py::arg("m0"), py::arg("P0"));

  m.def(
      "simulate",
      [](const Model& model, int steps, std::uint64_t seed) {
        Trajectory t = Simulate(model, SimulationOptions{steps, seed});
        return py::make_tuple(t.x, t.y);
      },
      py::arg("model"), py::arg("steps") = -1, py::arg("seed") = 1,
      "Draws x_0 ~ N(m0, P0), then x_k, y_k for k = 1..steps. Returns (x (T+1, n), y (T, m)); the same seed "
      "gives the same numbers on every platform (and as `kfx simulate`).");

  // ---- Kalman filter: functions ----
  py::class_<Estimate>(m, "Estimate", "A Gaussian estimate (x, P).")
      .def(py::init<Eigen::VectorXd, Eigen::MatrixXd>(), py::arg("x"), py::arg("P"))
      .def_readonly("x", &Estimate::x)
      .def_readonly("P", &Estimate::P);
  py::class_<UpdateResult>(m, "UpdateResult")
      .def_readonly("estimate", &UpdateResult::estimate)
      .def_readonly("innovation", &UpdateResult::innovation, "nu_k over the observed entries")
      .def_readonly("innovation_cov", &UpdateResult::innovation_cov, "S_k over the observed entries")
      .def_readonly("gain", &UpdateResult::gain, "n x num_observed filter gain K_k")
      .def_readonly("observed", &UpdateResult::observed)
      .def_readonly("log_likelihood", &UpdateResult::log_likelihood);
  m.def(
      "predict",
      [](const Estimate& e, const ModelStep& s, const std::string& form) {
        KalmanFilterOptions o;
        o.update_form = ParseUpdateForm(form);
        return Predict(e, s, o);
      },
      py::arg("estimate"), py::arg("step"), py::arg("update_form") = "joseph",
      "Time update x_{k|k-1} = A x, P_{k|k-1} = A P A^T + Q.");
  m.def(
      "update",
      [](const Estimate& e, const ModelStep& s, const Eigen::VectorXd& y, const std::string& form) {
        KalmanFilterOptions o;
        o.update_form = ParseUpdateForm(form);
        return Update(e, s, y, o);
      },
      py::arg("prior"), py::arg("step"), py::arg("y"), py::arg("update_form") = "joseph",
      "Measurement update with y (NaN entries are missing); Joseph form by default.");

  py::class_<FilterRun>(m, "FilterRun", "A whole-sequence filter run (kfx.run_filter).")
      .def_readonly("x_filt", &FilterRun::x_filt, "(T+1, n): row k = x_{k|k}; row 0 = m0")
      .def_readonly("x_pred", &FilterRun::x_pred, "(T+1, n): row k = x_{k|k-1}; row 0 = m0")
      .def_readonly("P_filt_diag", &FilterRun::P_filt_diag)
      .def_readonly("P_pred_diag", &FilterRun::P_pred_diag)
      .def_property_readonly(
          "P_filt", [](const FilterRun& r) { return Stack(r.P_filt); }, "(T+1, n, n) if stored")
      .def_property_readonly(
          "P_pred", [](const FilterRun& r) { return Stack(r.P_pred); }, "(T+1, n, n) if stored; [0] = P0")
      .def_readonly("innovations", &FilterRun::innovations, "(T, m), NaN where missing")
      .def_readonly("log_likelihood_terms", &FilterRun::log_likelihood_terms)
      .def_readonly("log_likelihood", &FilterRun::log_likelihood)
      .def_readonly("num_observed", &FilterRun::num_observed);
  m.def(
      "run_filter",
      [](const Model& model, const TimeSeries& y, bool store_covariances, const std::string& form) {
        FilterRunOptions o;
        o.store_covariances = store_covariances;
        o.filter.update_form = ParseUpdateForm(form);
        return RunFilter(model, y, o);
      },
      py::arg("model"), py::arg("y"), py::arg("store_covariances") = true, py::arg("update_form") = "joseph",
      "Runs the Kalman filter over y (T, m) (NaN = missing): predict then update for each row, starting "
      "from the prior (m0, P0) at k = 0.");
  py::class_<SmootherRun>(m, "SmootherRun")
      .def_readonly("x", &SmootherRun::x, "(T+1, n): row k = x_{k|T}")
      .def_readonly("P_diag", &SmootherRun::P_diag)
      .def_property_readonly(
          "P", [](const SmootherRun& r) { return Stack(r.P); }, "(T+1, n, n)");
  m.def("rts_smooth", &RtsSmooth, py::arg("model"), py::arg("run"),
        "Rauch-Tung-Striebel smoother of a run_filter result (needs store_covariances=True).");

  py::class_<KalmanSchedule>(m, "KalmanSchedule", "The offline part: gains and covariances, k = 1..T.")
      .def_property_readonly(
          "filter_gain", [](const KalmanSchedule& s) { return Stack(s.filter_gain, 1); }, "(T, n, m): K_1..K_T")
      .def_property_readonly(
          "P_pred", [](const KalmanSchedule& s) { return Stack(s.P_pred); }, "(T+1, n, n), [0] = P0")
      .def_property_readonly(
          "P_filt", [](const KalmanSchedule& s) { return Stack(s.P_filt); }, "(T+1, n, n), [0] = P0");
  m.def(
      "kalman_schedule",
      [](const Model& model, int steps) { return ComputeKalmanSchedule(model, KalmanScheduleOptions{steps}); },
      py::arg("model"), py::arg("steps") = -1);

  // ---- FilterPy-familiar class ----
  py::class_<PyKalmanFilter>(
      m, "KalmanFilter",
      "A Kalman filter with FilterPy's names: KalmanFilter(dim_x, dim_z) starts with F = I, H = 0, Q = I, R = I, "
      "x = 0, P = I; set the attributes, then call predict()/update(z), or batch_filter(zs) and "
      "rts_smoother(Xs, Ps). Differences to FilterPy (docs/python.md): x is 1-D (n,); batch_filter predicts "
      "before each update (x, P are the estimate at k = 0, the first measurement is of x_1); NaN entries of z "
      "are missing measurements; every assignment is validated (kfx.Error, a ValueError, naming the "
      "attribute).")
      .def(py::init<Eigen::Index, Eigen::Index>(), py::arg("dim_x"), py::arg("dim_z"))
      .def(py::init<const Model&>(), py::arg("model"), "From a time-invariant kfx.Model (x = m0, P = P0).")
      .def_property_readonly("dim_x", &PyKalmanFilter::dim_x)
      .def_property_readonly("dim_z", &PyKalmanFilter::dim_z)
      .def_property("x", &PyKalmanFilter::x, &PyKalmanFilter::set_x, "state estimate, shape (n,)")
      .def_property("P", &PyKalmanFilter::P, &PyKalmanFilter::set_P, "covariance (n, n)")
      .def_property("F", &PyKalmanFilter::F, &PyKalmanFilter::set_F, "state transition (kfx's A)")
      .def_property("H", &PyKalmanFilter::H, &PyKalmanFilter::set_H, "measurement matrix (kfx's C)")
      .def_property("Q", &PyKalmanFilter::Q, &PyKalmanFilter::set_Q, "process noise covariance")
      .def_property("R", &PyKalmanFilter::R, &PyKalmanFilter::set_R, "measurement noise covariance")
      .def_property_readonly(
          "K", [](const PyKalmanFilter& f) { return f.K_; }, "filter gain of the last update")
      .def_property_readonly(
          "y", [](const PyKalmanFilter& f) { return f.y_; }, "innovation of the last update")
      .def_property_readonly(
          "S", [](const PyKalmanFilter& f) { return f.S_; }, "innovation covariance")
      .def_property_readonly("log_likelihood", [](const PyKalmanFilter& f) { return f.log_likelihood_; })
      .def_property_readonly("x_prior", [](const PyKalmanFilter& f) { return f.prior_.x; })
      .def_property_readonly("P_prior", [](const PyKalmanFilter& f) { return f.prior_.P; })
      .def_property_readonly("x_post", [](const PyKalmanFilter& f) { return f.post_.x; })
      .def_property_readonly("P_post", [](const PyKalmanFilter& f) { return f.post_.P; })
      .def_property(
          "update_form",
          [](const PyKalmanFilter& f) {
            return std::string(f.options_.update_form == CovarianceUpdateForm::kJoseph ? "joseph" : "standard");
          },
          [](PyKalmanFilter& f, const std::string& s) { f.options_.update_form = ParseUpdateForm(s); },
          "'joseph' (default, PSD-preserving) or 'standard' (P - K H P)")
      .def("predict", &PyKalmanFilter::predict, "x = F x, P = F P F^T + Q.")
      .def("update", &PyKalmanFilter::update, py::arg("z"),
           "Measurement update with z (m,); NaN entries are missing (all NaN: no update).")
      .def(
          "update", [](PyKalmanFilter& f, double z) { f.update(Eigen::VectorXd::Constant(1, z)); }, py::arg("z"),
          "A scalar measurement (dim_z = 1).")
      .def("batch_filter", &PyKalmanFilter::batch_filter, py::arg("zs"), py::arg("update_state") = true,
           "Filters zs (T, m) in one call (kfx.run_filter): returns (means (T, n), covariances (T, n, n), "
           "means_p, covariances_p), predicted then updated for each row; x, P end at the last estimate.")
      .def("rts_smoother", &PyKalmanFilter::rts_smoother, py::arg("Xs"), py::arg("Ps"),
           "Rauch-Tung-Striebel smoother over filtered (Xs (T, n), Ps (T, n, n)) with this F, Q: returns "
           "(x, P, K, Pp) as FilterPy (K: smoother gains, Pp: predicted covariances F P F^T + Q).")
      .def("to_model", &PyKalmanFilter::AsModel, "The time-invariant kfx.Model (F, H, Q, R, x, P).");

  // ---- solvers ----
  py::class_<DareSolution>(m, "DareSolution",
                           "Filter DARE solution. Gains: filter gain K_f = P C^T (C P C^T + R)^{-1} (x_{k|k} = "
                           "x_{k|k-1} + K_f nu_k); predictor gain K_p = A K_f (x_{k+1|k} = A x_{k|k-1} + K_p nu_k).")
      .def_readonly("P_pred", &DareSolution::P_pred, "a priori P_{k|k-1}: the DARE solution")
      .def_readonly("P_filt", &DareSolution::P_filt, "a posteriori P_{k|k}")
      .def_readonly("filter_gain", &DareSolution::filter_gain, "K_f (n, m)")
      .def_readonly("predictor_gain", &DareSolution::predictor_gain, "K_p = A K_f (n, m)")
      .def_readonly("innovation_cov", &DareSolution::innovation_cov)
      .def_property_readonly(
          "method_used", [](const DareSolution& s) { return std::string(ToString(s.method_used)); },
          "'doubling' or 'schur': what produced the result")
      .def_readonly("fell_back", &DareSolution::fell_back, "method 'auto': doubling failed and Schur was tried")
      .def_readonly("refinement_steps", &DareSolution::refinement_steps)
      .def_readonly("closed_loop_spectral_radius", &DareSolution::closed_loop_spectral_radius)
      .def_readonly("min_eigenvalue", &DareSolution::min_eigenvalue)
      .def_readonly("eigenvalues_exact", &DareSolution::eigenvalues_exact,
                    "True: closed_loop_spectral_radius and min_eigenvalue are eigenvalues; False: the Lyapunov "
                    "certificate's bounds (rho <= closed_loop_spectral_radius, lambda_min(P) >= min_eigenvalue)")
      .def_readonly("lyapunov_certified", &DareSolution::lyapunov_certified)
      .def_readonly("summary", &DareSolution::summary, "How the solve ended (kfx.Summary).");
  m.def(
      "solve_filter_dare",
      [](const Eigen::MatrixXd& A, const Eigen::MatrixXd& C, const Eigen::MatrixXd& Q, const Eigen::MatrixXd& R,
         const std::string& method, int max_iterations, double tolerance, bool refine, bool exact_eigenvalues) {
        DareOptions o;
        o.method = ParseEnum<DareMethod>("method", method);
        o.max_iterations = max_iterations;
        o.tolerance = tolerance;
        o.refine = refine;
        o.exact_eigenvalues = exact_eigenvalues;
        return SolveFilterDare(A, C, Q, R, o);
      },
      py::arg("A"), py::arg("C"), py::arg("Q"), py::arg("R"), py::arg("method") = "auto",
      py::arg("max_iterations") = 60, py::arg("tolerance") = 1e-14, py::arg("refine") = true,
      py::arg("exact_eigenvalues") = false,
      "Filter DARE P = A P A^T + Q - A P C^T (C P C^T + R)^{-1} C P A^T (prediction form; scipy's "
      "solve_discrete_are(A.T, C.T, Q, R) gives the same P). Numerical failures are in .summary.termination, "
      "never raised. Stability is proven by a Lyapunov certificate whose bounds the summary reports; "
      "exact_eigenvalues=True reports rho(A - K_p C) and lambda_min(P) from the eigenvalues instead.");
  m.def("filter_dare_residual", &FilterDareResidual, py::arg("A"), py::arg("C"), py::arg("Q"), py::arg("R"),
        py::arg("P"));
  py::class_<LyapunovSolution>(m, "LyapunovSolution")
      .def_readonly("X", &LyapunovSolution::X, "the solution (n, n)")
      .def_readonly("spectral_radius", &LyapunovSolution::spectral_radius, "rho(A) from the Schur form (NaN: Smith)")
      .def_readonly("summary", &LyapunovSolution::summary, "How the solve ended (kfx.Summary).");
  m.def(
      "solve_discrete_lyapunov",
      [](const Eigen::MatrixXd& A, const Eigen::MatrixXd& Q, const std::string& method) {
        LyapunovOptions o;
        o.method = ParseEnum<LyapunovMethod>("method", method);
        py::gil_scoped_release release;
        return SolveDiscreteLyapunov(A, Q, o);
      },
      py::arg("A"), py::arg("Q"), py::arg("method") = "auto",
      "X = A X A^T + Q (the convention of scipy.linalg.solve_discrete_lyapunov): method 'auto' (the squared "
      "Smith iteration when it converges, else 'schur'), 'schur' (SLICOT SB03MD) or 'smith'. Returns a "
      "LyapunovSolution; a singular equation is .summary.termination 'singular', never raised.");
  m.def(
      "spectral_radius", [](const Eigen::MatrixXd& A) { return SpectralRadius(A); }, py::arg("A"));
  m.def("matrix_exponential", &MatrixExponential, py::arg("M"));
  m.def(
      "discretize_zoh",
      [](const Eigen::MatrixXd& A, const Eigen::MatrixXd& B, double dt) {
        auto d = DiscretizeZoh(A, B, dt);
        return py::make_tuple(d.Ad, d.Bd);
      },
      py::arg("A"), py::arg("B"), py::arg("dt"), "Zero-order hold: (Ad, Bd).");
  m.def(
      "discretize_process_noise",
      [](const Eigen::MatrixXd& A, const Eigen::MatrixXd& Qc, double dt) {
        auto d = DiscretizeProcessNoise(A, Qc, dt);
        return py::make_tuple(d.Ad, d.Qd);
      },
      py::arg("A"), py::arg("Qc"), py::arg("dt"), "Van Loan: (Ad, Qd = int_0^dt e^{As} Qc e^{A^T s} ds).");

  // ---- linear filters and the exact-performance engine ----
  py::class_<LinearFilterStep>(m, "LinearFilterStep")
      .def(py::init([](Eigen::MatrixXd Phi, Eigen::MatrixXd K, std::optional<Eigen::MatrixXd> O) {
             return LinearFilterStep{std::move(Phi), std::move(K), OrEmpty(O)};
           }),
           py::arg("Phi"), py::arg("K"), py::arg("O") = py::none())
      .def_readonly("Phi", &LinearFilterStep::Phi)
      .def_readonly("K", &LinearFilterStep::K)
      .def_readonly("O", &LinearFilterStep::O);
  py::class_<LinearFilter>(m, "LinearFilter",
                           "Any kfx filter as a linear recursion z_k = Phi_k z_{k-1} + K_k y_k, estimate O_k z_k "
                           "(O empty = identity). Evaluate it with exact_performance.")
      .def(py::init([](const Eigen::MatrixXd& Phi, const Eigen::MatrixXd& K, Eigen::VectorXd z0,
                       std::optional<Eigen::MatrixXd> O, std::optional<Eigen::MatrixXd> O0) {
             return LinearFilter(LinearFilterStep{Phi, K, OrEmpty(O)}, std::move(z0), OrEmpty(O0));
           }),
           py::arg("Phi"), py::arg("K"), py::arg("z0"), py::arg("O") = py::none(), py::arg("O0") = py::none(),
           "Time-invariant filter.")
      .def(py::init<std::vector<LinearFilterStep>, Eigen::VectorXd, Eigen::MatrixXd>(), py::arg("steps"), py::arg("z0"),
           py::arg("O0") = Eigen::MatrixXd(), "Time-varying filter over k = 1..len(steps).")
      .def_property_readonly("state_dim", &LinearFilter::state_dim)
      .def_property_readonly("meas_dim", &LinearFilter::meas_dim)
      .def_property_readonly("output_dim", &LinearFilter::output_dim)
      .def_property_readonly("time_invariant", &LinearFilter::time_invariant)
      .def_property_readonly("horizon", &LinearFilter::horizon)
      .def_property_readonly("z0", &LinearFilter::z0)
      .def(
          "step", [](const LinearFilter& f, int k) { return *f.step(k); }, py::arg("k"))
      .def(
          "run", [](const LinearFilter& f, const TimeSeries& y) { return RunLinearFilter(f, y); }, py::arg("y"),
          "The online part on y (T, m): estimates O_k z_k, k = 0..T, as (T+1, n_out).");
  m.def(
      "kalman_as_linear_filter",
      [](const Model& model, int steps) {
        return KalmanAsLinearFilter(model, ComputeKalmanSchedule(model, KalmanScheduleOptions{steps}));
      },
      py::arg("model"), py::arg("steps") = -1,
      "The Kalman filter of `model` as a LinearFilter: Phi_k = (I - K_k C_k) A_k, gain K_k, z_0 = m0.");
  m.def("constant_gain_as_linear_filter", &ConstantGainAsLinearFilter, py::arg("design"), py::arg("filter_gain"),
        py::arg("z0"), "Phi = (I - K_f C) A, K = K_f, O = I (e.g. with the steady-state DareSolution.filter_gain).");

  py::class_<PerformanceResult>(m, "PerformanceResult")
      .def_readonly("mse", &PerformanceResult::mse, "tr E[e_k e_k^T], k = 0..T")
      .def_readonly("weighted_mse", &PerformanceResult::weighted_mse)
      .def_readonly("bias", &PerformanceResult::bias, "(T+1, n): E[e_k]")
      .def_property_readonly(
          "error_moment", [](const PerformanceResult& r) { return Stack(r.error_moment); }, "(T+1, n, n)")
      .def_readonly("summary", &PerformanceResult::summary);
  m.def(
      "exact_performance",
      [](const Model& truth, const LinearFilter& filter, int steps, std::optional<Eigen::MatrixXd> weight,
         bool store_error_moments) {
        PerformanceOptions o;
        o.steps = steps;
        o.weight = OrEmpty(weight);
        o.store_error_moments = store_error_moments;
        py::gil_scoped_release release;
        return ExactPerformance(truth, filter, o);
      },
      py::arg("truth"), py::arg("filter"), py::arg("steps") = -1, py::arg("weight") = py::none(),
      py::arg("store_error_moments") = true,
      "The exact mean-square error of any linear filter on any true model (the one engine every kfx "
      "method reports through), e_k = x_k - O_k z_k.");
  py::class_<StationaryPerformance>(m, "StationaryPerformance")
      .def_property_readonly(
          "method", [](const StationaryPerformance& s) { return std::string(ToString(s.method)); },
          "'joint' or 'error-coordinates': the equation solved")
      .def_readonly("error_cov", &StationaryPerformance::error_cov)
      .def_readonly("mse", &StationaryPerformance::mse)
      .def_readonly("weighted_mse", &StationaryPerformance::weighted_mse)
      .def_readonly("summary", &StationaryPerformance::summary,
                    "termination 'converged', or 'unstable' when the error has no stationary value");
  m.def(
      "exact_stationary_performance",
      [](const Model& truth, const LinearFilter& filter, std::optional<Eigen::MatrixXd> weight) {
        StationaryPerformanceOptions o;
        o.weight = OrEmpty(weight);
        return ExactStationaryPerformance(truth, filter, o);
      },
      py::arg("truth"), py::arg("filter"), py::arg("weight") = py::none());
  py::class_<MonteCarloResult>(m, "MonteCarloResult")
      .def_readonly("runs", &MonteCarloResult::runs)
      .def_readonly("mse", &MonteCarloResult::mse)
      .def_readonly("mse_std_error", &MonteCarloResult::mse_std_error)
      .def_readonly("weighted_mse", &MonteCarloResult::weighted_mse)
      .def_readonly("weighted_mse_std_error", &MonteCarloResult::weighted_mse_std_error)
      .def_readonly("bias", &MonteCarloResult::bias)
      .def_property_readonly("error_moment", [](const MonteCarloResult& r) { return Stack(r.error_moment); })
      .def_readonly("summary", &MonteCarloResult::summary);
  m.def(
      "monte_carlo_performance",
      [](const Model& truth, const LinearFilter& filter, int runs, std::uint64_t seed, int steps,
         std::optional<Eigen::MatrixXd> weight, bool store_error_moments) {
        MonteCarloOptions o;
        o.runs = runs;
        o.seed = seed;
        o.steps = steps;
        o.weight = OrEmpty(weight);
        o.store_error_moments = store_error_moments;
        py::gil_scoped_release release;
        return MonteCarloPerformance(truth, filter, o);
      },
      py::arg("truth"), py::arg("filter"), py::arg("runs") = 1000, py::arg("seed") = 1, py::arg("steps") = -1,
      py::arg("weight") = py::none(), py::arg("store_error_moments") = false,
      "Monte Carlo estimate of the same quantities (run i uses stream seed i of `seed`).");

  // ---- reproduce ----
  m.def("paper_ids", &PaperIds, "The ids accepted by reproduce(), in paper order.");
  m.def(
      "reproduce",
      [](const std::string& paper, bool quick, const std::string& out_dir) {
        std::vector<std::string> ids = paper == "all" ? PaperIds() : std::vector<std::string>{paper};
        py::list items;
        for (const auto& id : ids) {
          ReproduceOptions o;
          o.quick = quick;
          if (!out_dir.empty()) o.out_dir = paper == "all" ? out_dir + "/" + id : out_dir;
          PaperReport r;
          {
            py::gil_scoped_release release;
            r = Reproduce(id, o);
          }
          for (const auto& it : r.items) items.append(ItemToDict(id, it));
        }
        return items;
      },
      py::arg("paper"), py::arg("quick") = false, py::arg("out_dir") = "",
      "A paper's published numbers beside kfx's, as a list of dicts (keys: paper, key, description, published, "
      "value, rel_diff, tolerance, status, note). paper: one of paper_ids() or 'all'. out_dir: where CSV data "
      "for figures goes (kfx.plots.render(out_dir) draws them).");
}

}  // namespace
}  // namespace kfx::python

PYBIND11_MODULE(_core, m) {
  m.doc() = "kfx: Kalman filtering for large and infinite-dimensional linear systems (compiled core; import kfx).";
  m.attr("__version__") = KFX_VERSION;
  kfx::python::BindCore(m);
  kfx::python::BindPapers(m);
}
