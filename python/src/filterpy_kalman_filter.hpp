#pragma once
// The state and the arithmetic of kfx.KalmanFilter, the drop-in for filterpy.kalman.KalmanFilter 1.4.5
// (docs/python.md, "kfx.KalmanFilter and FilterPy"). Bound by bind_filterpy_kalman_filter.cpp; the
// Python subclass in python/kfx/_filterpy.py adds __repr__, test_matrix_dimensions and pickling.
//
// Every attribute FilterPy users read or edit (F, H, Q, R, B, M, x, P, K, y, S, SI, z, x_prior, ...) is
// a Slot: a value in C++ and, once Python has seen or assigned it, the numpy array that is then its
// truth, so that in-place edits (kf.F[0, 1] = dt, kf.P *= 1000) take effect. A step writes new values
// and drops the arrays: the next read gives a new array, as FilterPy's x = dot(F, x) does, so that
// xs.append(kf.x) in a loop keeps every step's estimate. Nothing is copied to Python unless read.
#include <Eigen/Dense>
#include <optional>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "kfx/kalman_filter.hpp"
#include "kfx/model.hpp"

namespace kfx::python {

using RowMat = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
using CRef = Eigen::Ref<const RowMat>;

struct Slot {
  RowMat value;         // the value while `array` is null (rows x cols; a vector is rows x 1)
  py::object array;     // the numpy array Python holds (float64, C order): the truth while set
  bool vector = false;  // shown as a 1-D array of value.rows() entries
  bool none = false;    // B (no control input) and z (before any measurement): None
  // The current value as a matrix (the array's buffer, its shape checked: it may have been changed
  // in place). `name` names the attribute in errors.
  Eigen::Map<const RowMat> View(const char* name) const;
  // The array for Python (made from the value on first read, then kept).
  py::object Get();
  // A new value: the old array, if any, is left to whoever holds it.
  void Put(const RowMat& v);
  void Drop() {
    if (array) array = py::object();
  }
  // value <- array, then drop the array (before a loop that runs without the GIL).
  void Settle(const char* name);
};

// A float64 C-ordered ndarray (read in place, without a copy).
bool IsPlainArray(py::handle v);
// v as a float64 C-ordered array (itself when it is one). @throws kfx::Error naming `name`.
py::array ToArray(py::handle v, const char* name);

// What a caller may give for a matrix attribute or argument.
enum class Scalar { kNone, kIdentity, kFill };  // a number becomes nothing, s I (P, Q and R arguments), s 1 1^T

class FilterPyKalmanFilter {
 public:
  FilterPyKalmanFilter(Eigen::Index dim_x, Eigen::Index dim_z, Eigen::Index dim_u);
  explicit FilterPyKalmanFilter(const Model& model);

  Eigen::Index n() const { return n_; }
  Eigen::Index m() const { return m_; }
  Eigen::Index dim_u() const { return dim_u_; }

  enum Attr { kX, kP, kF, kH, kQ, kR, kB, kM, kXPrior, kPPrior, kXPost, kPPost, kK, kY, kS, kZ, kNumAttrs };
  static const char* Name(int a);
  py::object Get(int a);
  // Assignment: shape checked; for the inputs (x, P, F, H, Q, R, B, M) also finite and P, Q, R symmetric
  // PSD unless `check` is false (a copy or unpickling restores what the original held).
  void Set(int a, py::handle v, bool check = true);
  py::object GetSI();
  void SetSI(py::handle v);
  double alpha() const;
  void set_alpha(double a);

  void Predict(py::handle u, py::handle B, py::handle F, py::handle Q);
  void PredictSteadyState(py::handle u, py::handle B);
  void Update(py::handle z, py::handle R, py::handle H, bool correlated);
  void UpdateSteadyState(py::handle z);
  void UpdateSequential(Eigen::Index start, py::handle z, py::handle R, py::handle H);
  py::tuple GetPrediction(py::handle u, py::handle B, py::handle F, py::handle Q);
  py::tuple GetUpdate(py::handle z);
  py::object ResidualOf(py::handle z);
  double LogLikelihood();
  double Likelihood();
  double Mahalanobis();
  void SetLikelihoods(py::handle log_likelihood, py::handle likelihood, py::handle mahalanobis);
  py::tuple BatchFilter(py::handle zs, py::handle Fs, py::handle Qs, py::handle Hs, py::handle Rs, py::handle Bs,
                        py::handle us, bool update_first, py::handle saver);
  py::tuple RtsSmoother(py::handle Xs, py::handle Ps, py::handle Fs, py::handle Qs);
  bool joseph() const { return joseph_; }
  void set_joseph(bool j) { joseph_ = j; }
  Model AsModel();

 private:
  // A matrix argument (or attribute value) of `rows` x `cols` from Python. @throws kfx::Error naming it.
  RowMat Matrix(py::handle v, const char* name, Eigen::Index rows, Eigen::Index cols, Scalar scalar) const;
  // z as FilterPy's reshape_z accepts it: a number, (k,), (k, 1) or (1, k). @throws kfx::Error.
  Eigen::VectorXd Measurement(py::handle z, Eigen::Index k, const char* name) const;
  void Measurement(py::handle z, Eigen::Index k, const char* name, Eigen::VectorXd& out) const;  // into out
  // B u (empty when there is no control input).
  Eigen::VectorXd ControlInput(py::handle u, py::handle B);
  // The steps on values (no Python object touched: batch_filter runs them without the GIL).
  void PredictStep(const CRef& F, const CRef& Q, const Eigen::VectorXd& bu);
  void UpdateStep(const Eigen::VectorXd* z, const CRef& H, const CRef& R, const RowMat* M);  // z null: None
  void SkipUpdate();
  // batch_filter's common case through kfx::RunFilter (filterpy_batch.cpp; nullopt: not applicable),
  // then its outputs and the attributes of its last step.
  std::optional<FilterRun> LibraryRun(const RowMat& Z, const std::vector<char>& has, const RowMat& F, const RowMat& H,
                                      const RowMat& Q, const RowMat& R);
  void PublishLibraryRun(const FilterRun& run, const RowMat& Z, const std::vector<char>& has, const RowMat& H,
                         const RowMat& R, double* mu, double* cv, double* mu_p, double* cv_p);
  void ResetLikelihoods() { log_likelihood_.reset(), likelihood_.reset(), mahalanobis_.reset(); }
  void EnsureSI();
  // x_out = F x + bu, P_out = alpha^2 F P F^T + Q (symmetrized), from the current x, P.
  void Prediction(const CRef& F, const CRef& Q, const Eigen::VectorXd& bu, RowMat& x_out, RowMat& P_out);
  // The update of the current x, P with rows `obs` of (z, H, R) (M: the cross-covariance, may be null),
  // into x_out, P_out and the scratch y_, S_, K_ (over the observed rows). @throws kfx::NumericalError.
  void Correction(const Eigen::VectorXd& z, const CRef& H, const CRef& R, const RowMat* M,
                  const std::vector<Eigen::Index>& obs, bool joseph, RowMat& x_out, RowMat& P_out);
  void Publish(const RowMat& x, const RowMat& P, int x_slot, int P_slot);

  Eigen::Index n_ = 0, m_ = 0, dim_u_ = 0;
  Slot slots_[kNumAttrs];
  Slot SI_;
  bool si_stale_ = false;
  double alpha_sq_ = 1.0;
  bool joseph_ = true;
  // The observed rows of the last update (its S over them is S_, for SI); FilterPy's lazy
  // log_likelihood, likelihood, mahalanobis (nullopt: computed on the next read).
  std::vector<Eigen::Index> observed_, obs_;
  std::optional<double> log_likelihood_, likelihood_, mahalanobis_;
  // Scratch of one step (sized once: no allocation per step).
  RowMat x1_, P1_, y_, S_, K_;
  Eigen::VectorXd z_;
};

}  // namespace kfx::python
