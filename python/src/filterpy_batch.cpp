// kfx.KalmanFilter.batch_filter and rts_smoother (filterpy_kalman_filter.hpp), with FilterPy's
// arguments and outputs. batch_filter runs the steps of predict() and update() in C++; without a saver
// it converts every input first and runs the loop with the GIL released.
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "filterpy_kalman_filter.hpp"
#include "kfx/error.hpp"
#include "kfx/kalman_filter.hpp"

namespace kfx::python {
namespace {

// A per-step list argument (Fs, Qs, ...): None, or a sequence of at least `steps` items.
std::optional<py::sequence> StepList(py::handle v, const char* name, size_t steps) {
  if (v.is_none()) return std::nullopt;
  if (!py::isinstance<py::sequence>(v) && !py::isinstance<py::array>(v))
    throw Error(std::string(name) + ": expected a sequence of one item per step");
  auto seq = py::reinterpret_borrow<py::sequence>(v);
  if (seq.size() < steps) {
    throw Error(std::string(name) + ": expected " + std::to_string(steps) + " items (one per measurement), got " +
                std::to_string(seq.size()));
  }
  return seq;
}

}  // namespace

py::tuple FilterPyKalmanFilter::BatchFilter(py::handle zs, py::handle Fs, py::handle Qs, py::handle Hs, py::handle Rs,
                                            py::handle Bs, py::handle us, bool update_first, py::handle saver) {
  // The measurements: a (T, m), (T, m, 1) or (T,) (m = 1) float array, or a sequence whose items are
  // measurements or None.
  // (T x m, row i = zs[i]; has[i] == 0: None).
  const py::ssize_t T = py::len(zs);
  RowMat Z(T, m_);
  std::vector<char> has(static_cast<size_t>(T), 1);
  if (IsPlainArray(zs)) {
    const auto a = py::reinterpret_borrow<py::array>(zs);
    if (a.size() != T * m_ || (a.ndim() == 1 && m_ != 1) || a.ndim() > 3 || (a.ndim() >= 2 && a.shape(1) != m_)) {
      throw Error("zs: expected shape (T, " + std::to_string(m_) + ") or (T, " + std::to_string(m_) +
                  ", 1), got shape " + NumpyShapeString(a));
    }
    Z = Eigen::Map<const RowMat>(static_cast<const double*>(a.data()), T, m_);
    if (Z.array().isInf().any()) throw Error("zs: expected finite entries (NaN: missing), got inf");
  } else {
    py::ssize_t i = 0;
    for (py::handle item : zs) {
      if (item.is_none()) {
        has[static_cast<size_t>(i)] = 0;
      } else {
        Z.row(i) = Measurement(item, m_, ("zs[" + std::to_string(i) + "]").c_str()).transpose();
      }
      ++i;
    }
  }
  const size_t steps = static_cast<size_t>(T);
  // Per-step matrices (FilterPy's predict(Q=q) and update(R=r) read a number as q I, r I).
  auto list = [&](py::handle v, const char* name, Eigen::Index rows, Eigen::Index cols, Scalar scalar) {
    std::vector<RowMat> out;
    if (auto seq = StepList(v, name, steps)) {
      for (size_t i = 0; i < steps; ++i) {
        const std::string who = std::string(name) + "[" + std::to_string(i) + "]";
        out.push_back(Matrix((*seq)[i], who.c_str(), rows, cols, scalar));
      }
    }
    return out;
  };
  const std::vector<RowMat> F = list(Fs, "Fs", n_, n_, Scalar::kNone), Q = list(Qs, "Qs", n_, n_, Scalar::kIdentity),
                            H = list(Hs, "Hs", m_, n_, Scalar::kNone), R = list(Rs, "Rs", m_, m_, Scalar::kIdentity);
  std::vector<Eigen::VectorXd> bu(steps);
  if (!us.is_none() || !Bs.is_none()) {
    const auto useq = StepList(us, "us", steps), bseq = StepList(Bs, "Bs", steps);
    for (size_t i = 0; i < steps; ++i) {
      const py::object u = useq ? py::object((*useq)[i]) : py::object(py::int_(0));
      const py::object b = bseq ? py::object((*bseq)[i]) : py::object(py::none());
      if (bseq && b.is_none()) continue;  // no control input at this step
      bu[i] = ControlInput(u, b);
    }
  }
  const RowMat F0 = slots_[kF].View("F"), Q0 = slots_[kQ].View("Q"), H0 = slots_[kH].View("H"),
               R0 = slots_[kR].View("R");
  for (int a = 0; a < kNumAttrs; ++a)
    if (a != kF && a != kH && a != kQ && a != kR && a != kB && a != kM) slots_[a].Settle(Name(a));
  const bool with_saver = !saver.is_none();
  // FilterPy's default call (one F, H, Q, R; no control input, no fading memory; predict first, no saver)
  // is kfx's own filter run (kfx::RunFilter and its small-size kernels), without the GIL; then the last
  // update once more here, for the attributes it leaves (y, S, K, z). Anything else, or matrices a
  // kfx::Model refuses (an R that is only semidefinite), runs the loop below.
  std::optional<FilterRun> library;
  if (!with_saver && F.empty() && Q.empty() && H.empty() && R.empty() && us.is_none() && Bs.is_none() &&
      !update_first && alpha_sq_ == 1.0 && steps > 0) {
    py::gil_scoped_release release;
    library = LibraryRun(Z, has, F0, H0, Q0, R0);
  }
  // Outputs: means (T, n) for a 1-D x, (T, n, 1) for a column x; covariances (T, n, n). Allocated after
  // the library's run, so that its buffers are freed below them: freed at the heap's top they would be
  // returned to the system and faulted in again by the next call (2-6x the time of a 1000-step run).
  const bool vector = slots_[kX].vector;
  const auto ti = static_cast<py::ssize_t>(steps);
  std::vector<py::ssize_t> mshape = {ti, n_};
  if (!vector) mshape.push_back(1);
  py::array_t<double> means(mshape), means_p(mshape), covs({ti, n_, n_}), covs_p({ti, n_, n_});
  double *mu = means.mutable_data(), *mu_p = means_p.mutable_data(), *cv = covs.mutable_data(),
         *cv_p = covs_p.mutable_data();
  if (library) {
    PublishLibraryRun(*library, Z, has, H0, R0, mu, cv, mu_p, cv_p);
    return py::make_tuple(means, covs, means_p, covs_p);
  }
  py::object save = with_saver ? saver.attr("save") : py::object();

  Eigen::VectorXd zi(m_);
  auto run = [&] {
    for (size_t i = 0; i < steps; ++i) {
      const CRef Fi = F.empty() ? CRef(F0) : CRef(F[i]), Qi = Q.empty() ? CRef(Q0) : CRef(Q[i]);
      const CRef Hi = H.empty() ? CRef(H0) : CRef(H[i]), Ri = R.empty() ? CRef(R0) : CRef(R[i]);
      auto predict = [&](double* x_out, double* P_out) {
        PredictStep(Fi, Qi, bu[i]);
        std::copy(slots_[kX].value.data(), slots_[kX].value.data() + n_, x_out + i * n_);
        std::copy(slots_[kP].value.data(), slots_[kP].value.data() + n_ * n_, P_out + i * n_ * n_);
      };
      auto update = [&](double* x_out, double* P_out) {
        zi = Z.row(static_cast<Eigen::Index>(i)).transpose();
        UpdateStep(has[i] ? &zi : nullptr, Hi, Ri, nullptr);
        std::copy(slots_[kX].value.data(), slots_[kX].value.data() + n_, x_out + i * n_);
        std::copy(slots_[kP].value.data(), slots_[kP].value.data() + n_ * n_, P_out + i * n_ * n_);
      };
      try {
        if (update_first) {
          update(mu, cv);
          predict(mu_p, cv_p);
        } else {
          predict(mu_p, cv_p);
          update(mu, cv);
        }
      } catch (const NumericalError& e) {
        throw NumericalError("batch_filter, zs[" + std::to_string(i) + "]: " + e.what());
      }
      if (with_saver) {
        save();
        for (int a = 0; a < kNumAttrs; ++a)
          if (a != kF && a != kH && a != kQ && a != kR && a != kB && a != kM) slots_[a].Settle(Name(a));
      }
    }
  };
  if (with_saver) {
    run();
  } else {
    py::gil_scoped_release release;
    run();
  }
  return py::make_tuple(means, covs, means_p, covs_p);
}

std::optional<FilterRun> FilterPyKalmanFilter::LibraryRun(const RowMat& Z, const std::vector<char>& has,
                                                          const RowMat& F, const RowMat& H, const RowMat& Q,
                                                          const RowMat& R) {
  const Eigen::Index T = Z.rows();
  std::optional<Model> model;
  try {
    model.emplace(MakeStep(F, H, Q, R), Eigen::VectorXd(slots_[kX].value), Eigen::MatrixXd(slots_[kP].value));
  } catch (const Error&) {
    return std::nullopt;
  }
  TimeSeries y = Z;
  for (Eigen::Index i = 0; i < T; ++i)
    if (!has[static_cast<size_t>(i)]) y.row(i).setConstant(std::numeric_limits<double>::quiet_NaN());
  FilterRunOptions options;
  options.filter.update_form = joseph_ ? CovarianceUpdateForm::kJoseph : CovarianceUpdateForm::kStandard;
  options.store_covariances = true;
  try {
    return RunFilter(*model, y, options);
  } catch (const NumericalError& e) {
    throw NumericalError(std::string("batch_filter: ") + e.what());
  }
}

void FilterPyKalmanFilter::PublishLibraryRun(const FilterRun& run, const RowMat& Z, const std::vector<char>& has,
                                             const RowMat& H, const RowMat& R, double* mu, double* cv, double* mu_p,
                                             double* cv_p) {
  const Eigen::Index T = Z.rows();
  const Eigen::Index nn = n_ * n_;
  for (Eigen::Index i = 0; i < T; ++i) {
    Eigen::Map<Eigen::RowVectorXd>(mu + i * n_, n_) = run.x_filt.row(i + 1);
    Eigen::Map<Eigen::RowVectorXd>(mu_p + i * n_, n_) = run.x_pred.row(i + 1);
    Eigen::Map<RowMat>(cv + i * nn, n_, n_) = run.P_filt[static_cast<size_t>(i + 1)];
    Eigen::Map<RowMat>(cv_p + i * nn, n_, n_) = run.P_pred[static_cast<size_t>(i + 1)];
  }
  // The last step's prior, then its update here: the attributes FilterPy leaves after the loop.
  slots_[kX].value = run.x_pred.row(T).transpose();
  slots_[kP].value = run.P_pred.back();
  Publish(slots_[kX].value, slots_[kP].value, kXPrior, kPPrior);
  const Eigen::VectorXd last = Z.row(T - 1).transpose();
  UpdateStep(has.back() ? &last : nullptr, H, R, nullptr);
  Eigen::Map<RowMat>(mu + (T - 1) * n_, n_, 1) = slots_[kX].value;
  Eigen::Map<RowMat>(cv + (T - 1) * nn, n_, n_) = slots_[kP].value;
}

py::tuple FilterPyKalmanFilter::RtsSmoother(py::handle Xs, py::handle Ps, py::handle Fs, py::handle Qs) {
  if (py::len(Xs) != py::len(Ps)) throw Error("Xs, Ps: the length of Xs and Ps must be the same");
  const py::array xa = ToFloatArray(Xs), pa = ToFloatArray(Ps);
  const py::ssize_t T = xa.ndim() >= 1 ? xa.shape(0) : 0;
  if (T < 1 || xa.size() != T * n_ || xa.ndim() > 3 || (xa.ndim() >= 2 && xa.shape(1) != n_) ||
      (xa.ndim() == 1 && n_ != 1))
    throw Error("Xs: expected shape (T, " + std::to_string(n_) + ") or (T, " + std::to_string(n_) +
                ", 1), T >= 1, got " + NumpyShapeString(xa));
  if (pa.ndim() != 3 || pa.shape(1) != n_ || pa.shape(2) != n_)
    throw Error("Ps: expected shape (T, " + std::to_string(n_) + ", " + std::to_string(n_) + "), got " +
                NumpyShapeString(pa));
  const size_t steps = static_cast<size_t>(T);
  const auto fseq = StepList(Fs, "Fs", steps), qseq = StepList(Qs, "Qs", steps);
  const RowMat F0 = slots_[kF].View("F"), Q0 = slots_[kQ].View("Q");
  // Outputs: x like Xs, P, the smoother gains K (zero for the last step) and Pp, FilterPy's predicted
  // covariances F_{k+1} P_k F_{k+1}^T + Q_{k+1}, with Pp[T-1] = Ps[T-1] (FilterPy leaves it so).
  py::array x = py::array(xa.dtype(), std::vector<py::ssize_t>(xa.shape(), xa.shape() + xa.ndim()), xa.data());
  py::array_t<double> P({T, n_, n_}), K({T, n_, n_}), Pp({T, n_, n_});
  const Eigen::Index nn = n_ * n_;
  double* xd = static_cast<double*>(x.mutable_data());
  std::copy(static_cast<const double*>(pa.data()), static_cast<const double*>(pa.data()) + T * nn, P.mutable_data());
  std::copy(P.data(), P.data() + T * nn, Pp.mutable_data());
  std::fill(K.mutable_data(), K.mutable_data() + T * nn, 0.0);
  for (py::ssize_t k = T - 2; k >= 0; --k) {
    const RowMat F = fseq ? Matrix((*fseq)[k + 1], "Fs", n_, n_, Scalar::kNone) : F0;
    const RowMat Q = qseq ? Matrix((*qseq)[k + 1], "Qs", n_, n_, Scalar::kIdentity) : Q0;
    Eigen::Map<RowMat> Pk(P.mutable_data() + k * nn, n_, n_), Pk1(P.mutable_data() + (k + 1) * nn, n_, n_);
    Eigen::Map<RowMat> Ppk(Pp.mutable_data() + k * nn, n_, n_), Kk(K.mutable_data() + k * nn, n_, n_);
    Eigen::Map<Eigen::VectorXd> xk(xd + k * n_, n_), xk1(xd + (k + 1) * n_, n_);
    const RowMat FP = F * Pk;
    Ppk = FP * F.transpose() + Q;
    // K = P_k F^T Pp^{-1}: solved with Pp's Cholesky factor (a pseudo-inverse when Pp is singular).
    const Eigen::LLT<RowMat> llt(Ppk);
    Kk = llt.info() == Eigen::Success ? RowMat(llt.solve(FP).transpose())
                                      : RowMat(Ppk.completeOrthogonalDecomposition().solve(FP).transpose());
    xk += Kk * (xk1 - F * xk);
    Pk += Kk * (Pk1 - Ppk) * Kk.transpose();
    const RowMat sym = 0.5 * (Pk + Pk.transpose());
    Pk = sym;
  }
  return py::make_tuple(x, P, K, Pp);
}

}  // namespace kfx::python
