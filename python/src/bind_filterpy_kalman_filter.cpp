// kfx._core: kfx.KalmanFilter, a Kalman filter with FilterPy's names and call style (dim_x, dim_z, F, H,
// predict(), update(z), batch_filter, rts_smoother) over kfx::Predict / kfx::Update / kfx::RunFilter /
// kfx::RtsSmooth (include/kfx/kalman_filter.hpp).
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "bindings.hpp"
#include "kfx/enum_text.hpp"
#include "kfx/error.hpp"
#include "kfx/kalman_filter.hpp"
#include "kfx/model.hpp"
#include "kfx/validation.hpp"

namespace kfx::python {
namespace {

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
    if (z.size() != m_) {
      throw Error("z: expected a measurement of length " + std::to_string(m_) + " (dim_z), got length " +
                  std::to_string(z.size()));
    }
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

}  // namespace

void BindFilterPyKalmanFilter(py::module_& m) {
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
          [](PyKalmanFilter& f, const std::string& s) {
            f.options_.update_form = ParseEnum<CovarianceUpdateForm>("update_form", s);
          },
          "'joseph' (default, PSD-preserving) or 'standard' (P - K H P)")
      .def("predict", &PyKalmanFilter::predict, "x = F x, P = F P F^T + Q.")
      .def(
          "update",
          [](PyKalmanFilter& f, const py::object& z) {
            // A Python number is a scalar measurement (dim_z = 1); anything else goes through the one
            // array conversion, its errors naming z.
            if (py::isinstance<py::float_>(z) || py::isinstance<py::int_>(z)) {
              f.update(Eigen::VectorXd::Constant(1, z.cast<double>()));
            } else {
              f.update(VectorArgument(z, "z"));
            }
          },
          py::arg("z"),
          "Measurement update with z (m,) (or a number when dim_z = 1); NaN entries are missing (all NaN: no "
          "update).")
      .def("batch_filter", &PyKalmanFilter::batch_filter, py::arg("zs"), py::arg("update_state") = true,
           "Filters zs (T, m) in one call (kfx.run_filter): returns (means (T, n), covariances (T, n, n), "
           "means_p, covariances_p), predicted then updated for each row; x, P end at the last estimate.")
      .def("rts_smoother", &PyKalmanFilter::rts_smoother, py::arg("Xs"), py::arg("Ps"),
           "Rauch-Tung-Striebel smoother over filtered (Xs (T, n), Ps (T, n, n)) with this F, Q: returns "
           "(x, P, K, Pp) as FilterPy (K: smoother gains, Pp: predicted covariances F P F^T + Q).")
      .def("to_model", &PyKalmanFilter::AsModel, "The time-invariant kfx.Model (F, H, Q, R, x, P).");
}

}  // namespace kfx::python
