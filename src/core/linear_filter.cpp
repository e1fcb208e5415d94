#include "kfx/linear_filter.hpp"

#include "kfx/error.hpp"
#include "kfx/step_schedule.hpp"
#include "kfx/validation.hpp"

namespace kfx {

namespace {
Eigen::Index OutputDim(const LinearFilterStep& s) { return s.O.size() == 0 ? s.Phi.rows() : s.O.rows(); }
bool HasGamma(const LinearFilterStep& s) { return s.Gamma.size() > 0 || s.Gamma.cols() > 0 || s.Gamma.rows() > 0; }
}  // namespace

void LinearFilter::Validate(const LinearFilterStep& s, const std::string& label) const {
  RequireShape(label + "Phi", s.Phi, n_z_, n_z_);
  RequireFinite(label + "Phi", s.Phi);
  RequireShape(label + "K", s.K, n_z_, m_);
  RequireFinite(label + "K", s.K);
  if (s.O.size() == 0) {
    if (n_out_ != n_z_) throw Error(label + "O: expected an output map (n_out != n_z), got none");
  } else {
    RequireShape(label + "O", s.O, n_out_, n_z_);
    RequireFinite(label + "O", s.O);
  }
  if (HasGamma(s)) {
    if (q_ == 0) {
      throw Error(label + "Gamma: expected none (the filter takes no known input: q = 0), got " +
                  ShapeString(s.Gamma.rows(), s.Gamma.cols()));
    }
    RequireShape(label + "Gamma", s.Gamma, n_z_, q_);
    RequireFinite(label + "Gamma", s.Gamma);
  }
}

LinearFilter::LinearFilter(LinearFilterStep step, Eigen::VectorXd z0, Eigen::MatrixXd O0)
    : kind_(Kind::kInvariant),
      n_z_(step.Phi.rows()),
      m_(step.K.cols()),
      n_out_(OutputDim(step)),
      q_(step.Gamma.cols()),
      z0_(std::move(z0)),
      O0_(O0.size() == 0 ? step.O : std::move(O0)) {
  Validate(step, "");
  RequireVector("z0", z0_, n_z_);
  if (O0_.size() > 0) RequireShape("O0", O0_, n_out_, n_z_);
  steps_.push_back(std::make_shared<const LinearFilterStep>(std::move(step)));
}

LinearFilter::LinearFilter(std::vector<LinearFilterStep> steps, Eigen::VectorXd z0, Eigen::MatrixXd O0)
    : kind_(Kind::kSequence), z0_(std::move(z0)) {
  if (steps.empty()) throw Error("steps: expected at least one filter step, got none");
  n_z_ = steps[0].Phi.rows();
  m_ = steps[0].K.cols();
  n_out_ = OutputDim(steps[0]);
  q_ = steps[0].Gamma.cols();
  horizon_ = static_cast<int>(steps.size());
  O0_ = O0.size() == 0 ? steps[0].O : std::move(O0);
  RequireVector("z0", z0_, n_z_);
  if (O0_.size() > 0) RequireShape("O0", O0_, n_out_, n_z_);
  for (size_t i = 0; i < steps.size(); ++i) {
    Validate(steps[i], "step " + std::to_string(i + 1) + ": ");
    steps_.push_back(std::make_shared<const LinearFilterStep>(std::move(steps[i])));
  }
}

LinearFilter::LinearFilter(Eigen::Index n_z, Eigen::Index m, Eigen::Index n_out, StepFunction function,
                           Eigen::VectorXd z0, Eigen::MatrixXd O0, int horizon, Eigen::Index q)
    : kind_(Kind::kFunction),
      n_z_(n_z),
      m_(m),
      n_out_(n_out),
      q_(q),
      horizon_(horizon < 0 ? -1 : horizon),
      function_(std::move(function)),
      z0_(std::move(z0)),
      O0_(std::move(O0)) {
  if (!function_) throw Error("function: expected a callable, got an empty std::function");
  if (q_ < 0) throw Error("q: expected a known input length >= 0, got " + std::to_string(q_));
  RequireVector("z0", z0_, n_z_);
  if (O0_.size() > 0) {
    RequireShape("O0", O0_, n_out_, n_z_);
  } else if (n_out_ != n_z_) {
    throw Error("O0: expected an output map for k = 0 (n_out != n_z), got none");
  }
}

LinearFilterStepPtr LinearFilter::step(int k) const {
  return detail::StepAt(
      k, kind_, horizon_, steps_, function_,
      [this](const LinearFilterStep& s, const std::string& label) { Validate(s, label); }, "filter step");
}

Eigen::VectorXd ApplyOutput(const Eigen::MatrixXd& O, const Eigen::VectorXd& z) {
  if (O.size() == 0) return z;
  return O * z;
}

TimeSeries RunLinearFilter(const LinearFilter& filter, const TimeSeries& y) {
  return RunLinearFilter(filter, y, TimeSeries(0, 0));
}

TimeSeries RunLinearFilter(const LinearFilter& filter, const TimeSeries& y, const TimeSeries& g) {
  RequireShape("y", y, -1, filter.meas_dim());
  RequireFinite("y", y);
  const int T = static_cast<int>(y.rows());
  if (filter.horizon() >= 0 && T > filter.horizon()) {
    throw Error("y: expected at most " + std::to_string(filter.horizon()) + " rows (the filter's horizon), got " +
                std::to_string(T));
  }
  const Eigen::Index q = filter.input_dim();
  if (g.cols() != q || (q > 0 && g.rows() < T)) {
    throw Error(q == 0 ? "g: expected no known input (the filter has no Gamma), got " + std::to_string(g.cols()) +
                             " columns"
                       : "g: expected a known input of " + std::to_string(T) + " rows and " + std::to_string(q) +
                             " columns (the filter's Gamma), got " + ShapeString(g.rows(), g.cols()));
  }
  if (q > 0 && !g.topRows(T).allFinite()) throw Error("g: expected finite entries");
  TimeSeries out(T + 1, filter.output_dim());
  Eigen::VectorXd z = filter.z0();
  out.row(0) = ApplyOutput(filter.O0(), z).transpose();
  Eigen::VectorXd next(z.size());
  for (int k = 1; k <= T; ++k) {
    const LinearFilterStepPtr s = filter.step(k);
    next.noalias() = s->Phi * z;
    next.noalias() += s->K * y.row(k - 1).transpose();
    if (s->Gamma.size() > 0) next.noalias() += s->Gamma * g.row(k - 1).transpose();
    z.swap(next);
    out.row(k) = ApplyOutput(s->O, z).transpose();
  }
  return out;
}

}  // namespace kfx
