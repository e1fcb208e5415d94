// The sampled filter of a continuous-time model (paper 003; include/kfx/compare.hpp): `sampled:dt=h`, the
// discrete Kalman filter of the continuous system sampled every h = j dt, run on the data's grid dt (the
// true model's: the increments of y every dt). Between its samples it sums the increments and predicts;
// every j-th step it updates with the increment over h. It becomes a LinearFilter on the data's grid, so
// the exact-performance engine evaluates it against the exact discrete-time equivalent of the continuous
// model there (SampledAtFileGrid), like every other method.
#include <cmath>
#include <sstream>

#include "compare/resolve_internal.hpp"
#include "kfx/continuous.hpp"
#include "kfx/discretize.hpp"
#include "kfx/error.hpp"
#include "kfx/kalman_filter.hpp"
#include "kfx/riccati.hpp"

namespace kfx::detail {

namespace {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

std::string Num(double v) {
  std::ostringstream os;
  os.precision(10);
  os << v;
  return os.str();
}

// The sampling ratio j = h / dt (a positive integer to within 1e-9 relative).
int Ratio(const MethodSpec& spec, double h, double dt) {
  const double ratio = h / dt;
  const double j = std::round(ratio);
  if (j < 1 || std::abs(ratio - j) > 1e-9 * ratio || j > 1e6) {
    throw Error(Where(spec) + "dt=" + spec.Get("dt") +
                " is not a positive integer multiple of the data's sampling step " + Num(dt) +
                " (the model file's dt)");
  }
  return static_cast<int>(j);
}

// The fine-grid steps of the sampled filter: state s = [z_hat (p); sum of increments since the last
// update (r)], output [z_hat at t_k; 0] (the estimate of the step integral is not formed).
class SampledSteps {
 public:
  SampledSteps(const ContinuousModel& m, double dt, int j, const MatrixXd& Phi, const MatrixXd& Gamma)
      : p_(m.state_dim()), r_(m.output_dim()), j_(j), Phi_(Phi), CGamma_(m.C * Gamma) {
    const MatrixXd step = MatrixExponential(m.A * dt);
    powers_.push_back(MatrixXd::Identity(p_, p_));
    for (int i = 1; i < j; ++i) powers_.push_back(step * powers_.back());
  }
  LinearFilterStep Step(int k, const MatrixXd& K) const {
    const int i = (k - 1) % j_ + 1;  // position within the sampling interval, 1..j
    const MatrixXd Kz = K.topRows(p_);
    LinearFilterStep s;
    s.Phi = MatrixXd::Zero(p_ + r_, p_ + r_);
    s.K = MatrixXd::Zero(p_ + r_, r_);
    s.O = MatrixXd::Zero(2 * p_, p_ + r_);
    if (i < j_) {
      s.Phi.topLeftCorner(p_, p_).setIdentity();
      if (i > 1) s.Phi.bottomRightCorner(r_, r_).setIdentity();
      s.K.bottomRows(r_).setIdentity();
      s.O.topLeftCorner(p_, p_) = powers_[static_cast<std::size_t>(i)];
    } else {
      // z+ = Phi z + Kz (Y - C Gamma z), Y = the increments summed over the interval.
      s.Phi.topLeftCorner(p_, p_) = Phi_ - Kz * CGamma_;
      if (j_ > 1) s.Phi.topRightCorner(p_, r_) = Kz;
      s.K.topRows(p_) = Kz;
      s.O.topLeftCorner(p_, p_).setIdentity();
    }
    return s;
  }
  int ratio() const { return j_; }

 private:
  Index p_, r_;
  int j_;
  MatrixXd Phi_, CGamma_;
  std::vector<MatrixXd> powers_;  // e^{A i dt}, i = 0..j-1
};

}  // namespace

ResolvedMethod ResolveSampled(const MethodSpec& spec, const ComparisonModel& truth, const MethodOptions& options) {
  if (!truth.continuous) {
    throw Error(Where(spec) +
                "sampled needs a continuous-time model (a \"kfx-continuous-model\" file, docs/formats.md), got a "
                "discrete-time one");
  }
  const ContinuousModel& cm = truth.continuous->model;
  const double dt = truth.continuous->dt;
  const int j = Ratio(spec, spec.GetPositiveNumber("dt"), dt);
  const double h = j * dt;
  const Index p = cm.state_dim(), r = cm.output_dim();
  // The discrete-time equivalent at the filter's own sampling h (the library's, paper 003).
  const Model one = SampledModel(cm, h, 1);
  const StepPtr coarse_ptr = one.step(1);
  const ModelStep& coarse = *coarse_ptr;
  auto steps =
      std::make_shared<const SampledSteps>(cm, dt, j, coarse.A.topLeftCorner(p, p), coarse.A.bottomLeftCorner(p, p));
  const bool steady = spec.Get("gain", options.stationary ? "steady" : "schedule") == "steady";
  std::vector<MatrixXd> gains;  // gains[c] for the c-th update (c >= 1); one gain when steady
  MatrixXd claimed_z;           // the filter's own covariance of z after its last update before T
  const int T = options.steps;
  const int updates = T / j;
  if (steady) {
    const DareSolution dare = SolveFilterDare(coarse.A, coarse.C, coarse.Q, coarse.R);
    if (!dare.summary.ok())
      throw NumericalError(Where(spec) + "DARE of the sampled model: " + dare.summary.BriefReport());
    gains = {MatrixXd(), dare.filter_gain};
    claimed_z = dare.P_filt.topLeftCorner(p, p);
  } else {
    KalmanScheduleOptions so;
    so.steps = std::max(1, (T + j - 1) / j);
    const KalmanSchedule sch = ComputeKalmanSchedule(Model(coarse, one.m0(), one.P0()), so);
    gains = sch.filter_gain;
    claimed_z = sch.P_filt[static_cast<std::size_t>(updates)].topLeftCorner(p, p);
  }
  MatrixXd O0 = MatrixXd::Zero(2 * p, p + r);
  O0.topLeftCorner(p, p).setIdentity();
  VectorXd z0 = VectorXd::Zero(p + r);
  z0.head(p) = cm.m0;
  ResolvedMethod out;
  if (j == 1 && steady) {
    out.filter = std::make_shared<LinearFilter>(steps->Step(1, gains[1]), z0, O0);
  } else {
    auto shared_gains = std::make_shared<const std::vector<MatrixXd>>(std::move(gains));
    const LinearFilter::StepFunction f = [steps, shared_gains, steady](int k) {
      const std::size_t c = steady ? 1 : static_cast<std::size_t>((k - 1) / steps->ratio() + 1);
      return steps->Step(k, (*shared_gains)[c]);
    };
    out.filter = std::make_shared<LinearFilter>(p + r, r, 2 * p, f, z0, O0, steady ? -1 : T);
  }
  // What it claims at T: its covariance after the last update, predicted over the rest of the interval.
  const int rest = T - updates * j;
  MatrixXd claimed = claimed_z;
  if (rest > 0 && !steady) {
    const IntegratedDiscretization d = DiscretizeIntegrated(cm.A, cm.ProcessNoise(), rest * dt);
    claimed = d.Phi * claimed_z * d.Phi.transpose() + d.Qzz;
  }
  MatrixXd embedded = MatrixXd::Zero(2 * p, 2 * p);
  embedded.topLeftCorner(p, p) = claimed;
  if (steady) {
    if (j == 1) out.claimed_cov = out.claimed_stationary_cov = embedded;
  } else {
    out.claimed_cov = embedded;
  }
  out.description = "Kalman filter of the continuous model sampled every " + Num(h) + " (" +
                    (j == 1 ? std::string("every step") : "every " + std::to_string(j) + " steps") + ", " +
                    (steady ? "steady gain" : "gain schedule") + ")";
  out.memory_bytes =
      8.0 * static_cast<double>((steady ? 1 : (T + j - 1) / j) * (2 * p * r) + j * p * p + 3 * p * p + (p + r));
  return out;
}

}  // namespace kfx::detail
