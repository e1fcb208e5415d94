// kfx.KalmanFilter (filterpy_kalman_filter.hpp): FilterPy's attributes as slots, its predict / update
// variants and their bookkeeping (x_prior, x_post, y, S, K, z, the lazy likelihoods). FilterPy's formulas
// with kfx's hygiene: S factored by Cholesky (never inverted to compute K), P symmetrized after each step;
// an S that is not positive definite raises kfx.NumericalError where FilterPy would invert it anyway.
// batch_filter and rts_smoother are in filterpy_batch.cpp.
#include "filterpy_kalman_filter.hpp"
#include "filterpy_kernels.hpp"

#include <cfloat>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "kfx/error.hpp"
#include "kfx/validation.hpp"

namespace kfx::python {
namespace {
using namespace filterpy;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kLog2Pi = 1.8378770664093454835606594728112;

std::string Shape(Eigen::Index rows, Eigen::Index cols) {
  return "(" + std::to_string(rows) + ", " + std::to_string(cols) + ")";
}

bool IsNumber(py::handle v) { return PyFloat_Check(v.ptr()) || PyLong_Check(v.ptr()); }

Eigen::Map<const RowMat> MapArray(const py::array& a, Eigen::Index rows, Eigen::Index cols) {
  return {static_cast<const double*>(a.data()), rows, cols};
}

}  // namespace

bool IsPlainArray(py::handle v) {
  if (!py::array_t<double>::check_(v)) return false;
  const auto a = py::reinterpret_borrow<py::array>(v);
  return (a.flags() & py::array::c_style) != 0;
}

py::array ToArray(py::handle v, const char* name) {
  if (IsPlainArray(v)) return py::reinterpret_borrow<py::array>(v);
  try {
    return ToFloatArray(v);
  } catch (const Error& e) {
    throw Error(std::string(name) + ": " + e.what());
  }
}

// ---- slots ----------------------------------------------------------------------------------------------

Eigen::Map<const RowMat> Slot::View(const char* name) const {
  const Eigen::Index rows = value.rows(), cols = value.cols();
  if (!array) return {value.data(), rows, cols};
  const auto a = py::reinterpret_borrow<py::array>(array);
  const bool shape_ok =
      vector ? (a.ndim() == 1 && a.shape(0) == rows) : (a.ndim() == 2 && a.shape(0) == rows && a.shape(1) == cols);
  if (!shape_ok || !IsPlainArray(array)) {
    throw Error(std::string(name) + ": the array was changed in place to shape " + NumpyShapeString(a) +
                " or another dtype; expected float64 " +
                (vector ? "(" + std::to_string(rows) + ",)" : Shape(rows, cols)) + " (assign a new array instead)");
  }
  return MapArray(a, rows, cols);
}

py::object Slot::Get() {
  if (none) return py::none();
  if (!array) {
    py::array_t<double> a =
        vector ? py::array_t<double>(value.rows()) : py::array_t<double>({value.rows(), value.cols()});
    std::copy(value.data(), value.data() + value.size(), a.mutable_data());
    array = std::move(a);
  }
  return array;
}

void Slot::Put(const RowMat& v) {
  value = v;
  none = false;
  Drop();
}

void Slot::Settle(const char* name) {
  if (!array) return;
  RowMat v = View(name);
  value.swap(v);
  array = py::object();
}

// ---- construction and attributes ---------------------------------------------------------------------

FilterPyKalmanFilter::FilterPyKalmanFilter(Eigen::Index dim_x, Eigen::Index dim_z, Eigen::Index dim_u) {
  if (dim_x < 1) throw Error("dim_x: expected >= 1, got " + std::to_string(dim_x));
  if (dim_z < 1) throw Error("dim_z: expected >= 1, got " + std::to_string(dim_z));
  if (dim_u < 0) throw Error("dim_u: expected >= 0, got " + std::to_string(dim_u));
  n_ = dim_x;
  m_ = dim_z;
  dim_u_ = dim_u;
  const RowMat I = RowMat::Identity(n_, n_);
  slots_[kX].value = RowMat::Zero(n_, 1);
  slots_[kP].value = I;
  slots_[kQ].value = I;
  slots_[kF].value = I;
  slots_[kH].value = RowMat::Zero(m_, n_);
  slots_[kR].value = RowMat::Identity(m_, m_);
  slots_[kM].value = RowMat::Zero(n_, m_);
  slots_[kB].value = RowMat::Zero(n_, std::max<Eigen::Index>(dim_u, 1));
  slots_[kB].none = true;
  slots_[kZ].value = RowMat::Constant(m_, 1, kNaN);
  slots_[kZ].none = true;
  slots_[kK].value = RowMat::Zero(n_, m_);
  slots_[kY].value = RowMat::Zero(m_, 1);
  slots_[kS].value = RowMat::Zero(m_, m_);
  SI_.value = RowMat::Zero(m_, m_);
  for (int a : {kXPrior, kXPost}) slots_[a].value = slots_[kX].value;
  for (int a : {kPPrior, kPPost}) slots_[a].value = I;
  log_likelihood_ = std::log(DBL_MIN);
  likelihood_ = DBL_MIN;
}

FilterPyKalmanFilter::FilterPyKalmanFilter(const Model& model)
    : FilterPyKalmanFilter(model.state_dim(), model.meas_dim(), 0) {
  if (!model.time_invariant()) throw Error("model: expected a time-invariant model (use kfx.run_filter)");
  const StepPtr s = model.step(1);
  slots_[kF].value = s->A;
  slots_[kH].value = s->C;
  slots_[kQ].value = s->Q;
  slots_[kR].value = s->R;
  slots_[kX].value = model.m0();
  slots_[kP].value = model.P0();
  slots_[kXPrior].value = slots_[kXPost].value = slots_[kX].value;
  slots_[kPPrior].value = slots_[kPPost].value = slots_[kP].value;
}

const char* FilterPyKalmanFilter::Name(int a) {
  static const char* const kNames[kNumAttrs] = {"x",       "P",       "F",      "H",      "Q", "R", "B", "M",
                                                "x_prior", "P_prior", "x_post", "P_post", "K", "y", "S", "z"};
  return kNames[a];
}

py::object FilterPyKalmanFilter::Get(int a) {
  if (a == kZ && slots_[kZ].none) {  // FilterPy's np.array([[None] * dim_z]).T
    py::list col;
    for (Eigen::Index i = 0; i < m_; ++i) col.append(py::make_tuple(py::none()));
    return py::module_::import("numpy").attr("array")(col, py::arg("dtype") = "object");
  }
  return slots_[a].Get();
}

RowMat FilterPyKalmanFilter::Matrix(py::handle v, const char* name, Eigen::Index rows, Eigen::Index cols,
                                    Scalar scalar) const {
  const py::array a = ToArray(v, name);
  if (a.ndim() == 0 || (a.size() == 1 && rows * cols != 1 && scalar != Scalar::kNone && a.ndim() <= 2)) {
    const double s = *static_cast<const double*>(a.data());
    if (rows * cols == 1) return RowMat::Constant(1, 1, s);
    if (scalar == Scalar::kIdentity && rows == cols) return s * RowMat::Identity(rows, cols);
    if (scalar == Scalar::kFill) return RowMat::Constant(rows, cols, s);
    throw Error(std::string(name) + ": expected shape " + Shape(rows, cols) + ", got a number");
  }
  if (a.ndim() == 2 && (rows < 0 || a.shape(0) == rows) && (cols < 0 || a.shape(1) == cols)) {
    return MapArray(a, a.shape(0), a.shape(1));
  }
  // A vector where a matrix with one row or one column is meant: H (n,) for dim_z = 1, B (n,), R (1,).
  if (a.ndim() == 1 && ((rows <= 1 && a.shape(0) == cols) || ((cols == 1 || cols < 0) && a.shape(0) == rows))) {
    return (rows <= 1 && a.shape(0) == cols) ? RowMat(MapArray(a, 1, a.shape(0))) : RowMat(MapArray(a, a.shape(0), 1));
  }
  const std::string r = rows < 0 ? "k" : std::to_string(rows), c = cols < 0 ? "k" : std::to_string(cols);
  throw Error(std::string(name) + ": expected shape (" + r + ", " + c + "), got shape " + NumpyShapeString(a));
}

void FilterPyKalmanFilter::Set(int a, py::handle v, bool check) {
  Slot& s = slots_[a];
  const char* name = Name(a);
  if ((a == kB || a == kZ) && v.is_none()) {
    s.Drop();
    s.none = true;
    return;
  }
  const bool state_vector = a == kX || a == kXPrior || a == kXPost || a == kY || a == kZ;
  const Eigen::Index rows = (a == kH || a == kR || a == kY || a == kZ || a == kS) ? m_ : n_;
  const Eigen::Index cols = state_vector
                                ? 1
                                : (a == kB                                                                     ? -1
                                   : (a == kH || a == kF || a == kQ || a == kP || a == kPPrior || a == kPPost) ? n_
                                                                                                               : m_);
  RowMat value;
  bool vector = false;
  if (state_vector) {
    const py::array arr = ToArray(v, name);
    vector = arr.ndim() == 1;
    if (!((vector && arr.shape(0) == rows) || (arr.ndim() == 2 && arr.shape(0) == rows && arr.shape(1) == 1))) {
      throw Error(std::string(name) + ": expected shape (" + std::to_string(rows) + ",) or " + Shape(rows, 1) +
                  ", got shape " + NumpyShapeString(arr));
    }
    value = MapArray(arr, rows, 1);
  } else {
    // FilterPy's arithmetic on a number: P = p makes F P F^T = p F F^T (p I); Q = q and R = r are added
    // to every entry of F P F^T and H P H^T (q 1 1^T, r 1 1^T: the same as q I for dim 1).
    const Scalar scalar = a == kP ? Scalar::kIdentity : (a == kQ || a == kR || a > kM) ? Scalar::kFill : Scalar::kNone;
    value = Matrix(v, name, rows, cols, scalar);
  }
  if (check && a <= kM) {
    const Eigen::MatrixXd cm = value;
    RequireFinite(name, cm);
    if (a == kP || a == kQ || a == kR) RequirePositiveSemidefinite(name, cm);
  }
  s.none = false;
  s.vector = vector;
  // The caller's own array when it is already what kfx reads (float64, C order, this shape): kept,
  // so that later in-place edits of it take effect, as in FilterPy.
  const bool keep = IsPlainArray(v) && [&] {
    const auto arr = py::reinterpret_borrow<py::array>(v);
    return vector ? arr.ndim() == 1 : (arr.ndim() == 2 && arr.shape(0) == value.rows() && arr.shape(1) == value.cols());
  }();
  s.value = std::move(value);
  s.array = keep ? py::reinterpret_borrow<py::object>(v) : py::object();
  if (a == kS) si_stale_ = false;  // FilterPy's SI is its own attribute
}

void FilterPyKalmanFilter::EnsureSI() {
  if (!si_stale_) return;
  RowMat SI = RowMat::Constant(m_, m_, kNaN);
  const RowMat inv = Eigen::LLT<RowMat>(S_).solve(RowMat::Identity(S_.rows(), S_.rows()));
  for (size_t i = 0; i < observed_.size(); ++i)
    for (size_t j = 0; j < observed_.size(); ++j) SI(observed_[i], observed_[j]) = inv(i, j);
  SI_.Put(SI);
  si_stale_ = false;
}

py::object FilterPyKalmanFilter::GetSI() {
  EnsureSI();
  return SI_.Get();
}

void FilterPyKalmanFilter::SetSI(py::handle v) {
  SI_.value = Matrix(v, "SI", m_, m_, Scalar::kNone);
  SI_.Drop();
  si_stale_ = false;
}

double FilterPyKalmanFilter::alpha() const { return std::sqrt(alpha_sq_); }

void FilterPyKalmanFilter::set_alpha(double a) {
  if (!(a >= 1.0) || !std::isfinite(a)) throw Error("alpha: expected a number >= 1, got " + std::to_string(a));
  alpha_sq_ = a * a;
}

// ---- measurements and inputs -------------------------------------------------------------------------

void FilterPyKalmanFilter::Measurement(py::handle z, Eigen::Index k, const char* name, Eigen::VectorXd& out) const {
  if (IsNumber(z) && k == 1) {
    const double v = z.cast<double>();
    if (std::isinf(v)) throw Error(std::string(name) + ": expected finite entries (NaN: missing), got inf");
    out.setConstant(1, v);
    return;
  }
  const py::array a = ToArray(z, name);
  const bool ok = (a.ndim() == 0 && k == 1) || (a.ndim() == 1 && a.shape(0) == k) ||
                  (a.ndim() == 2 && ((a.shape(0) == k && a.shape(1) == 1) || (a.shape(0) == 1 && a.shape(1) == k)));
  if (!ok) {
    throw Error(std::string(name) + ": expected a measurement of length " + std::to_string(k) +
                " (a number when 1, shape (" + std::to_string(k) + ",), " + Shape(k, 1) + " or " + Shape(1, k) +
                "), got shape " + NumpyShapeString(a));
  }
  out = Eigen::Map<const Eigen::VectorXd>(static_cast<const double*>(a.data()), k);
  if (out.array().isInf().any()) throw Error(std::string(name) + ": expected finite entries (NaN: missing), got inf");
}

Eigen::VectorXd FilterPyKalmanFilter::Measurement(py::handle z, Eigen::Index k, const char* name) const {
  Eigen::VectorXd v;
  Measurement(z, k, name, v);
  return v;
}

Eigen::VectorXd FilterPyKalmanFilter::ControlInput(py::handle u, py::handle B) {
  if (u.is_none()) return {};
  RowMat b;
  if (!B.is_none()) {
    b = Matrix(B, "B", n_, -1, Scalar::kNone);
  } else if (!slots_[kB].none) {
    b = slots_[kB].View("B");
  } else {
    return {};
  }
  if (IsNumber(u) || ToArray(u, "u").size() == 1) {
    const double s = IsNumber(u) ? u.cast<double>() : *static_cast<const double*>(ToArray(u, "u").data());
    if (b.cols() != 1) throw Error("u: a number needs B with one column, B is " + Shape(b.rows(), b.cols()));
    return b.col(0) * s;
  }
  const py::array a = ToArray(u, "u");
  if (a.size() != b.cols()) {
    throw Error("u: expected " + std::to_string(b.cols()) + " entries (the columns of B), got shape " +
                NumpyShapeString(a));
  }
  return b * Eigen::Map<const Eigen::VectorXd>(static_cast<const double*>(a.data()), b.cols());
}

// ---- the arithmetic ----------------------------------------------------------------------------------

void FilterPyKalmanFilter::Prediction(const CRef& F, const CRef& Q, const Eigen::VectorXd& bu, RowMat& x_out,
                                      RowMat& P_out) {
  const auto x = slots_[kX].View("x");
  const auto P = slots_[kP].View("P");
  if (n_ <= kSmallMax) return PredictKernel<SmallMat>(x, P, F, Q, bu, alpha_sq_, x_out, P_out);
  PredictKernel<RowMat>(x, P, F, Q, bu, alpha_sq_, x_out, P_out);
}

void FilterPyKalmanFilter::Correction(const Eigen::VectorXd& z, const CRef& H, const CRef& R, const RowMat* M,
                                      const std::vector<Eigen::Index>& obs, bool joseph, RowMat& x_out, RowMat& P_out) {
  const auto x = slots_[kX].View("x");
  const auto P = slots_[kP].View("P");
  const bool small = n_ <= kSmallMax && static_cast<Eigen::Index>(obs.size()) <= kSmallMax;
  const bool ok = small ? CorrectKernel<SmallMat>(x, P, z, H, R, M, obs, joseph, x_out, P_out, y_, S_, K_)
                        : CorrectKernel<RowMat>(x, P, z, H, R, M, obs, joseph, x_out, P_out, y_, S_, K_);
  if (!ok) {
    throw NumericalError(
        "update: the innovation covariance S = H P H^T + R" + std::string(M ? " + H M + M^T H^T" : "") +
        " is not positive definite (check that R > 0 and P >= 0); FilterPy would invert it and go on with a "
        "covariance that is no longer positive semidefinite, kfx stops");
  }
}

void FilterPyKalmanFilter::Publish(const RowMat& x, const RowMat& P, int x_slot, int P_slot) {
  const bool vector = slots_[kX].vector;
  slots_[x_slot].Put(x);
  slots_[x_slot].vector = vector;
  slots_[P_slot].Put(P);
}

// ---- the steps -----------------------------------------------------------------------------------------

void FilterPyKalmanFilter::Predict(py::handle u, py::handle B, py::handle F, py::handle Q) {
  RowMat Fa, Qa;
  const CRef Fr = F.is_none() ? CRef(slots_[kF].View("F")) : CRef(Fa = Matrix(F, "F", n_, n_, Scalar::kNone));
  const CRef Qr = Q.is_none() ? CRef(slots_[kQ].View("Q")) : CRef(Qa = Matrix(Q, "Q", n_, n_, Scalar::kIdentity));
  PredictStep(Fr, Qr, ControlInput(u, B));
}

void FilterPyKalmanFilter::PredictStep(const CRef& F, const CRef& Q, const Eigen::VectorXd& bu) {
  Prediction(F, Q, bu, x1_, P1_);
  slots_[kX].value.swap(x1_);
  slots_[kX].Drop();
  slots_[kP].value.swap(P1_);
  slots_[kP].Drop();
  Publish(slots_[kX].value, slots_[kP].value, kXPrior, kPPrior);
}

void FilterPyKalmanFilter::PredictSteadyState(py::handle u, py::handle B) {
  const auto F = slots_[kF].View("F");
  const Eigen::VectorXd bu = ControlInput(u, B);
  x1_.noalias() = F * slots_[kX].View("x");
  if (bu.size() != 0) x1_ += bu;
  slots_[kX].value.swap(x1_);
  slots_[kX].Drop();
  slots_[kP].Settle("P");
  Publish(slots_[kX].value, slots_[kP].value, kXPrior, kPPrior);
}

void FilterPyKalmanFilter::SkipUpdate() {
  ResetLikelihoods();
  slots_[kZ].Drop();
  slots_[kZ].none = true;
  slots_[kY].Put(RowMat::Zero(m_, 1));
  slots_[kY].vector = false;  // FilterPy: zeros((dim_z, 1)) whatever x's shape
  slots_[kX].Settle("x");
  slots_[kP].Settle("P");
  Publish(slots_[kX].value, slots_[kP].value, kXPost, kPPost);
}

void FilterPyKalmanFilter::Update(py::handle z, py::handle R, py::handle H, bool correlated) {
  if (z.is_none()) return SkipUpdate();
  RowMat Ha, Ra, Ma;
  const CRef Hr = H.is_none() ? CRef(slots_[kH].View("H")) : CRef(Ha = Matrix(H, "H", -1, n_, Scalar::kNone));
  const Eigen::Index k = Hr.rows();
  const CRef Rr = R.is_none() ? CRef(slots_[kR].View("R")) : CRef(Ra = Matrix(R, "R", k, k, Scalar::kIdentity));
  if (Rr.rows() != k)
    throw Error("R: expected shape " + Shape(k, k) + " (the rows of H), got " + Shape(Rr.rows(), Rr.cols()));
  if (correlated) {
    Ma = slots_[kM].View("M");
    if (Ma.cols() != k)
      throw Error("M: expected " + std::to_string(k) + " columns (the rows of H), got " + std::to_string(Ma.cols()));
  }
  Measurement(z, k, "z", z_);
  UpdateStep(&z_, Hr, Rr, correlated ? &Ma : nullptr);
}

void FilterPyKalmanFilter::UpdateStep(const Eigen::VectorXd* z, const CRef& H, const CRef& R, const RowMat* M) {
  if (!z) return SkipUpdate();
  const Eigen::VectorXd& zv = *z;
  const Eigen::Index k = H.rows();
  std::vector<Eigen::Index>& obs = obs_;  // reused: no allocation per step
  obs.clear();
  for (Eigen::Index i = 0; i < k; ++i)
    if (!std::isnan(zv(i))) obs.push_back(i);
  if (obs.empty()) {  // every entry missing: no update, as update(None), but z is kept
    SkipUpdate();
    slots_[kZ].Put(zv);
    slots_[kZ].vector = slots_[kX].vector;
    return;
  }
  Correction(zv, H, R, M, obs, M != nullptr || joseph_, x1_, P1_);
  ResetLikelihoods();
  // y, K, S over all k rows: NaN (y, S) and zero (K) at missing entries.
  const bool all = static_cast<Eigen::Index>(obs.size()) == k;
  if (all) {
    slots_[kY].Put(y_);
    slots_[kK].Put(K_);
    slots_[kS].Put(S_);
  } else {
    RowMat y = RowMat::Constant(k, 1, kNaN), K = RowMat::Zero(n_, k), S = RowMat::Constant(k, k, kNaN);
    for (size_t i = 0; i < obs.size(); ++i) {
      y(obs[i], 0) = y_(i, 0);
      K.col(obs[i]) = K_.col(i);
      for (size_t j = 0; j < obs.size(); ++j) S(obs[i], obs[j]) = S_(i, j);
    }
    slots_[kY].Put(y);
    slots_[kK].Put(K);
    slots_[kS].Put(S);
  }
  const bool vector = slots_[kX].vector;
  slots_[kY].vector = vector;
  slots_[kZ].Put(zv);
  slots_[kZ].vector = vector;
  observed_.swap(obs);
  si_stale_ = true;
  slots_[kX].value.swap(x1_);
  slots_[kX].Drop();
  slots_[kP].value.swap(P1_);
  slots_[kP].Drop();
  Publish(slots_[kX].value, slots_[kP].value, kXPost, kPPost);
}

void FilterPyKalmanFilter::UpdateSteadyState(py::handle z) {
  if (z.is_none()) return SkipUpdate();
  const Eigen::VectorXd zv = Measurement(z, m_, "z");
  const auto H = slots_[kH].View("H");
  const auto K = slots_[kK].View("K");
  RowMat y = zv - H * slots_[kX].View("x");
  x1_ = slots_[kX].View("x");
  for (Eigen::Index i = 0; i < m_; ++i)
    if (!std::isnan(y(i, 0))) x1_ += K.col(i) * y(i, 0);
  ResetLikelihoods();
  const bool vector = slots_[kX].vector;
  slots_[kY].Put(y);
  slots_[kY].vector = vector;
  slots_[kZ].Put(zv);
  slots_[kZ].vector = vector;
  slots_[kX].value.swap(x1_);
  slots_[kX].Drop();
  slots_[kP].Settle("P");
  Publish(slots_[kX].value, slots_[kP].value, kXPost, kPPost);
}

void FilterPyKalmanFilter::UpdateSequential(Eigen::Index start, py::handle z, py::handle R, py::handle H) {
  const py::array za = ToArray(z, "z_i");
  const Eigen::Index len = za.ndim() == 0 ? 1 : za.shape(0);
  if (za.size() != len) throw Error("z_i: expected a number or shape (k,) / (k, 1), got shape " + NumpyShapeString(za));
  if (start < 0 || start + len > m_) {
    throw Error("start: expected rows start .. start + " + std::to_string(len) +
                " within dim_z = " + std::to_string(m_) + ", got start = " + std::to_string(start));
  }
  const Eigen::VectorXd zv = Eigen::Map<const Eigen::VectorXd>(static_cast<const double*>(za.data()), len);
  const RowMat Hi = H.is_none() ? RowMat(slots_[kH].View("H").middleRows(start, len))
                                : RowMat(Matrix(H, "H_i", len, n_, Scalar::kNone));
  const RowMat Ri = R.is_none() ? RowMat(slots_[kR].View("R").block(start, start, len, len))
                                : RowMat(Matrix(R, "R_i", len, len, Scalar::kIdentity));
  std::vector<Eigen::Index> obs;
  for (Eigen::Index i = 0; i < len; ++i)
    if (!std::isnan(zv(i))) obs.push_back(i);
  RowMat y = slots_[kY].View("y"), K = slots_[kK].View("K"),
         zs = slots_[kZ].none ? RowMat::Constant(m_, 1, kNaN) : RowMat(slots_[kZ].View("z"));
  zs.middleRows(start, len) = zv;
  if (!obs.empty()) {
    Correction(zv, Hi, Ri, nullptr, obs, joseph_, x1_, P1_);
    for (size_t i = 0; i < obs.size(); ++i) {
      y(start + obs[i], 0) = y_(i, 0);
      K.col(start + obs[i]) = K_.col(i);
    }
    slots_[kX].value.swap(x1_);
    slots_[kX].Drop();
    slots_[kP].value.swap(P1_);
    slots_[kP].Drop();
  }
  const bool y_vector = slots_[kY].vector, z_vector = slots_[kZ].none ? slots_[kX].vector : slots_[kZ].vector;
  slots_[kY].Put(y);
  slots_[kY].vector = y_vector;
  slots_[kK].Put(K);
  slots_[kZ].Put(zs);
  slots_[kZ].vector = z_vector;
  slots_[kX].Settle("x");
  slots_[kP].Settle("P");
  Publish(slots_[kX].value, slots_[kP].value, kXPost, kPPost);
}

// ---- queries -----------------------------------------------------------------------------------------

namespace {
using namespace filterpy;
py::array StateArray(const RowMat& v, bool vector) {
  py::array_t<double> a = vector ? py::array_t<double>(v.rows()) : py::array_t<double>({v.rows(), v.cols()});
  std::copy(v.data(), v.data() + v.size(), a.mutable_data());
  return std::move(a);
}
}  // namespace

py::tuple FilterPyKalmanFilter::GetPrediction(py::handle u, py::handle B, py::handle F, py::handle Q) {
  RowMat Fa, Qa, x, P;
  const CRef Fr = F.is_none() ? CRef(slots_[kF].View("F")) : CRef(Fa = Matrix(F, "F", n_, n_, Scalar::kNone));
  const CRef Qr = Q.is_none() ? CRef(slots_[kQ].View("Q")) : CRef(Qa = Matrix(Q, "Q", n_, n_, Scalar::kIdentity));
  Prediction(Fr, Qr, ControlInput(u, B), x, P);
  return py::make_tuple(StateArray(x, slots_[kX].vector), StateArray(P, false));
}

py::tuple FilterPyKalmanFilter::GetUpdate(py::handle z) {
  if (z.is_none()) return py::make_tuple(Get(kX), Get(kP));
  const Eigen::VectorXd zv = Measurement(z, m_, "z");
  std::vector<Eigen::Index> obs;
  for (Eigen::Index i = 0; i < m_; ++i)
    if (!std::isnan(zv(i))) obs.push_back(i);
  RowMat x = slots_[kX].View("x"), P = slots_[kP].View("P");
  if (!obs.empty()) {
    EnsureSI();  // SI belongs to the last update (Correction overwrites the scratch S_)
    Correction(zv, slots_[kH].View("H"), slots_[kR].View("R"), nullptr, obs, true, x, P);
  }
  return py::make_tuple(StateArray(x, slots_[kX].vector), StateArray(P, false));
}

py::object FilterPyKalmanFilter::ResidualOf(py::handle z) {
  const RowMat r = Measurement(z, m_, "z") - slots_[kH].View("H") * slots_[kXPrior].View("x_prior");
  return StateArray(r, slots_[kX].vector);
}

double FilterPyKalmanFilter::LogLikelihood() {
  if (log_likelihood_) return *log_likelihood_;
  // FilterPy: logpdf(y, cov=S) over the observed entries of y; -inf when S is not positive definite.
  const auto y = slots_[kY].View("y");
  const auto S = slots_[kS].View("S");
  std::vector<Eigen::Index> obs;
  for (Eigen::Index i = 0; i < y.rows(); ++i)
    if (!std::isnan(y(i, 0))) obs.push_back(i);
  const Eigen::Index k = static_cast<Eigen::Index>(obs.size());
  RowMat So(k, k);
  Eigen::VectorXd yo(k);
  for (Eigen::Index i = 0; i < k; ++i) {
    yo(i) = y(obs[i], 0);
    for (Eigen::Index j = 0; j < k; ++j) So(i, j) = S(obs[i], obs[j]);
  }
  const Eigen::LLT<RowMat> llt(So);
  double ll = -std::numeric_limits<double>::infinity();
  if (llt.info() == Eigen::Success && k > 0) {
    const Eigen::VectorXd w = llt.matrixL().solve(yo);
    ll = -0.5 * (static_cast<double>(k) * kLog2Pi + w.squaredNorm()) -
         llt.matrixL().toDenseMatrix().diagonal().array().log().sum();
  } else if (k == 0) {
    ll = 0.0;
  }
  log_likelihood_ = ll;
  return ll;
}

double FilterPyKalmanFilter::Likelihood() {
  if (!likelihood_) {
    const double l = std::exp(LogLikelihood());
    likelihood_ = l == 0.0 ? DBL_MIN : l;
  }
  return *likelihood_;
}

double FilterPyKalmanFilter::Mahalanobis() {
  if (!mahalanobis_) {  // sqrt(y^T SI y) over the observed entries
    EnsureSI();
    const auto y = slots_[kY].View("y");
    const auto SI = SI_.View("SI");
    double d = 0.0;
    for (Eigen::Index i = 0; i < y.rows(); ++i)
      for (Eigen::Index j = 0; j < y.rows(); ++j)
        if (!std::isnan(y(i, 0)) && !std::isnan(y(j, 0))) d += y(i, 0) * SI(i, j) * y(j, 0);
    mahalanobis_ = std::sqrt(d);
  }
  return *mahalanobis_;
}

void FilterPyKalmanFilter::SetLikelihoods(py::handle log_likelihood, py::handle likelihood, py::handle mahalanobis) {
  auto opt = [](py::handle v) {
    return v.is_none() ? std::optional<double>() : std::optional<double>(v.cast<double>());
  };
  log_likelihood_ = opt(log_likelihood);
  likelihood_ = opt(likelihood);
  mahalanobis_ = opt(mahalanobis);
}

Model FilterPyKalmanFilter::AsModel() {
  auto cm = [&](int a) { return Eigen::MatrixXd(slots_[a].View(Name(a))); };
  return Model(MakeStep(cm(kF), cm(kH), cm(kQ), cm(kR)), Eigen::VectorXd(cm(kX)), cm(kP));
}

}  // namespace kfx::python
