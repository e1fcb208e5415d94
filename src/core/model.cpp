#include "kfx/model.hpp"

#include "kfx/error.hpp"
#include "kfx/step_schedule.hpp"
#include "kfx/validation.hpp"

namespace kfx {

ModelStep MakeStep(Eigen::MatrixXd A, Eigen::MatrixXd C, Eigen::MatrixXd Q, Eigen::MatrixXd R) {
  ModelStep s;
  s.A = std::move(A);
  s.C = std::move(C);
  s.Q = std::move(Q);
  s.R = std::move(R);
  return s;
}

ModelStep MakeStepWithNoiseInput(Eigen::MatrixXd A, Eigen::MatrixXd B, Eigen::MatrixXd U, Eigen::MatrixXd C,
                                 Eigen::MatrixXd R) {
  RequireShape("B", B, A.rows(), -1);
  RequireShape("U", U, B.cols(), B.cols());
  RequireFinite("B", B);
  RequireFinite("U", U);
  ModelStep s;
  s.Q = B * U * B.transpose();
  Symmetrize(s.Q);
  s.A = std::move(A);
  s.B = std::move(B);
  s.U = std::move(U);
  s.C = std::move(C);
  s.R = std::move(R);
  return s;
}

namespace {

// Zero dimensions are rejected here, at the one validation every model passes (library, model files, Python):
// a model has at least one state and one measurement (issue 20, class 3).
void RequireDimensions(Eigen::Index n, Eigen::Index m, const std::string& a_name, const std::string& c_name) {
  if (n < 1) {
    throw Error(a_name + ": expected at least one state (n >= 1), got n = " + std::to_string(n) +
                " (zero dimensions are not supported)");
  }
  if (m < 1) {
    throw Error(c_name + ": expected at least one measurement (m >= 1), got m = " + std::to_string(m) +
                " (zero dimensions are not supported)");
  }
}

}  // namespace

void ValidateStep(const ModelStep& s, Eigen::Index n, Eigen::Index m, const std::string& label) {
  RequireShape(label + "A", s.A, n, n);
  RequireFinite(label + "A", s.A);
  RequireShape(label + "C", s.C, m, n);
  RequireFinite(label + "C", s.C);
  // B and U before Q: with a noise input, Q = B U B^T is derived from them, and a fault in U must
  // be reported as U's (docs/robustness.md, class 12).
  const bool noise_input = s.B.size() > 0 || s.U.size() > 0;
  if (noise_input) {
    RequireShape(label + "B", s.B, n, -1);
    RequireFinite(label + "B", s.B);
    RequireShape(label + "U", s.U, s.B.cols(), s.B.cols());
    RequirePositiveSemidefinite(label + "U", s.U);
  }
  RequireShape(label + "Q", s.Q, n, n);
  RequirePositiveSemidefinite(label + "Q", s.Q);
  RequireShape(label + "R", s.R, m, m);
  RequirePositiveDefinite(label + "R", s.R);
  if (noise_input) {
    const Eigen::MatrixXd bub = s.B * s.U * s.B.transpose();
    const double scale = std::max(1.0, bub.cwiseAbs().maxCoeff());
    if ((bub - s.Q).cwiseAbs().maxCoeff() > 1e-10 * scale) {
      throw Error(label + "Q: expected Q = B U B^T when a noise input B is given");
    }
  }
}

Model::Model(ModelStep step, Eigen::VectorXd m0, Eigen::MatrixXd P0)
    : kind_(Kind::kInvariant), n_(step.A.rows()), m_(step.C.rows()), m0_(std::move(m0)), P0_(std::move(P0)) {
  RequireSquare("A", step.A);
  RequireDimensions(n_, m_, "A", "C");
  ValidateStep(step, n_, m_);
  steps_.push_back(std::make_shared<const ModelStep>(std::move(step)));
  ValidatePrior();
}

Model::Model(std::vector<ModelStep> steps, Eigen::VectorXd m0, Eigen::MatrixXd P0)
    : kind_(Kind::kSequence), m0_(std::move(m0)), P0_(std::move(P0)) {
  if (steps.empty()) throw Error("steps: expected at least one step, got none");
  RequireSquare("step 1: A", steps[0].A);
  n_ = steps[0].A.rows();
  m_ = steps[0].C.rows();
  RequireDimensions(n_, m_, "step 1: A", "step 1: C");
  horizon_ = static_cast<int>(steps.size());
  steps_.reserve(steps.size());
  for (size_t i = 0; i < steps.size(); ++i) {
    ValidateStep(steps[i], n_, m_, "step " + std::to_string(i + 1) + ": ");
    steps_.push_back(std::make_shared<const ModelStep>(std::move(steps[i])));
  }
  ValidatePrior();
}

Model::Model(Eigen::Index n, Eigen::Index m, StepFunction function, Eigen::VectorXd m0, Eigen::MatrixXd P0, int horizon)
    : kind_(Kind::kFunction),
      n_(n),
      m_(m),
      horizon_(horizon < 0 ? -1 : horizon),
      function_(std::move(function)),
      m0_(std::move(m0)),
      P0_(std::move(P0)) {
  RequireDimensions(n, m, "n", "m");
  if (!function_) throw Error("function: expected a callable, got an empty std::function");
  ValidatePrior();
}

void Model::ValidatePrior() {
  RequireVector("m0", m0_, n_);
  RequireShape("P0", P0_, n_, n_);
  RequirePositiveSemidefinite("P0", P0_);
}

StepPtr Model::step(int k) const {
  return detail::StepAt(
      k, kind_, horizon_, steps_, function_,
      [this](const ModelStep& s, const std::string& label) { ValidateStep(s, n_, m_, label); }, "step");
}

int Model::ResolveSteps(int steps, const std::string& what) const {
  if (steps < 0) {
    if (horizon_ < 0) throw Error(what + ": expected a number of steps (the model has no horizon)");
    return horizon_;
  }
  if (horizon_ >= 0 && steps > horizon_) {
    throw Error(what + ": expected at most " + std::to_string(horizon_) + " steps (the model's horizon), got " +
                std::to_string(steps));
  }
  return steps;
}

Model Model::WithPrior(Eigen::VectorXd m0, Eigen::MatrixXd P0) const {
  Model copy = *this;
  copy.m0_ = std::move(m0);
  copy.P0_ = std::move(P0);
  copy.ValidatePrior();
  return copy;
}

}  // namespace kfx
