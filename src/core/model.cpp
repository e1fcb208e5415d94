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
  if (s.G.size() > 0 || s.G.cols() > 0) {
    RequireShape(label + "G", s.G, n, -1);
    RequireFinite(label + "G", s.G);
  }
  if (s.D.size() > 0 || s.D.cols() > 0) {
    RequireShape(label + "D", s.D, m, s.G.size() > 0 ? s.G.cols() : -1);
    RequireFinite(label + "D", s.D);
  }
  if (s.S.size() > 0 || s.S.rows() > 0 || s.S.cols() > 0) {
    RequireShape(label + "S", s.S, n, m);
    RequireFinite(label + "S", s.S);
    Eigen::MatrixXd joint(n + m, n + m);
    joint << 0.5 * s.Q + 0.5 * s.Q.transpose(), s.S, s.S.transpose(), 0.5 * s.R + 0.5 * s.R.transpose();
    RequirePositiveSemidefinite(label + "S (the joint covariance [[Q, S], [S^T, R]])", joint);
  }
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
  const Eigen::Index q = steps[0].input_dim();
  steps_.reserve(steps.size());
  for (size_t i = 0; i < steps.size(); ++i) {
    ValidateStep(steps[i], n_, m_, "step " + std::to_string(i + 1) + ": ");
    if (steps[i].input_dim() != q) {
      throw Error("step " + std::to_string(i + 1) + ": " + (steps[i].G.size() > 0 ? "G" : "D") +
                  ": expected the known input length q = " + std::to_string(q) +
                  " of step 1, got q = " + std::to_string(steps[i].input_dim()));
    }
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

Eigen::Index Model::input_dim() const { return step(1)->input_dim(); }

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

namespace {

// G g and D g of a step whose known input g (length q) has been checked.
KnownInputTerms TermsOf(const ModelStep& step, const Eigen::Ref<const Eigen::VectorXd>& g) {
  KnownInputTerms t;
  if (step.G.size() > 0) t.state.noalias() = step.G * g;
  if (step.D.size() > 0) t.measurement.noalias() = step.D * g;
  return t;
}

}  // namespace

KnownInputTerms KnownInputOf(const ModelStep& step, const Eigen::Ref<const Eigen::VectorXd>& g) {
  const Eigen::Index q = step.input_dim();
  if (!step.has_known_input()) {
    if (g.size() > 0) {
      throw Error("g: expected no known input (the step has no G or D), got a vector of length " +
                  std::to_string(g.size()));
    }
    return KnownInputTerms{};
  }
  if (g.size() != q) {
    throw Error("g: expected the known input g_k of length " + std::to_string(q) + " (the step's G, D)" +
                (g.size() == 0 ? std::string(", got none") : ", got length " + std::to_string(g.size())));
  }
  if (!g.allFinite()) throw Error("g: expected finite entries (a known input has no missing values)");
  return TermsOf(step, g);
}

KnownInputTerms KnownInputAt(const ModelStep& step, const TimeSeries& g, int k) {
  const Eigen::Index q = step.input_dim();
  if (!step.has_known_input()) {
    if (g.cols() > 0) {
      throw Error("g: expected no known input (step " + std::to_string(k) + " has no G or D), got " +
                  std::to_string(g.cols()) + " columns");
    }
    return KnownInputTerms{};
  }
  if (g.cols() != q || g.rows() < k) {
    throw Error("g: expected a known input of " + std::to_string(q) + " columns and at least " + std::to_string(k) +
                " rows (row k-1 = g_k), got " + ShapeString(g.rows(), g.cols()));
  }
  const auto gk = g.row(k - 1).transpose();
  if (!gk.allFinite()) throw Error("g (row " + std::to_string(k - 1) + "): expected finite entries");
  return TermsOf(step, gk);
}

void RequireKnownInput(const Model& model, const TimeSeries& g, int T) {
  const Eigen::Index q = model.input_dim();
  if (q == 0) {
    if (g.cols() > 0) {
      throw Error("g: expected no known input (the model has no G or D), got " + std::to_string(g.cols()) + " columns");
    }
    return;
  }
  if (g.cols() != q || g.rows() < T) {
    throw Error("g: expected a known input of " + std::to_string(T) + " rows and " + std::to_string(q) +
                " columns (the model's G, D), got " + ShapeString(g.rows(), g.cols()));
  }
  if (!g.topRows(T).allFinite()) throw Error("g: expected finite entries (a known input has no missing values)");
}

}  // namespace kfx
