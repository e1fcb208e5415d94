#include "kfx/simulation.hpp"

#include <cmath>

#include "kfx/error.hpp"
#include "kfx/validation.hpp"

namespace kfx {

double Rng::Uniform() {
  // 53 random bits -> (0, 1): (bits + 0.5) / 2^53 is never 0 or 1.
  const std::uint64_t bits = engine_() >> 11;
  return (static_cast<double>(bits) + 0.5) * (1.0 / 9007199254740992.0);
}

double Rng::Normal() {
  if (has_spare_) {
    has_spare_ = false;
    return spare_;
  }
  const double u1 = Uniform();
  const double u2 = Uniform();
  const double r = std::sqrt(-2.0 * std::log(u1));
  const double t = 2.0 * M_PI * u2;
  spare_ = r * std::sin(t);
  has_spare_ = true;
  return r * std::cos(t);
}

Eigen::VectorXd Rng::Normal(Eigen::Index n) {
  Eigen::VectorXd v(n);
  for (Eigen::Index i = 0; i < n; ++i) v(i) = Normal();
  return v;
}

std::uint64_t Rng::StreamSeed(std::uint64_t seed, std::uint64_t stream) {
  auto splitmix = [](std::uint64_t z) {
    z += 0x9e3779b97f4a7c15ULL;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  };
  return splitmix(splitmix(seed) ^ (stream * 0xd1b54a32d192ed03ULL + 1));
}

Eigen::MatrixXd PsdFactor(const Eigen::Ref<const Eigen::MatrixXd>& M) {
  const Eigen::Index n = M.rows();
  if (n == 0) return Eigen::MatrixXd(0, 0);
  // 0.5 M + 0.5 M^T, not 0.5 (M + M^T): the sum overflows for entries above DBL_MAX / 2 (Q = 1e308).
  const Eigen::MatrixXd sym = 0.5 * M + 0.5 * M.transpose();
  Eigen::LDLT<Eigen::MatrixXd> ldlt(sym);
  const double scale = std::max(sym.diagonal().cwiseAbs().maxCoeff(), 1e-300);
  if (ldlt.info() == Eigen::Success && ldlt.vectorD().minCoeff() >= -1e-12 * scale) {
    Eigen::MatrixXd L = ldlt.matrixL();
    const Eigen::VectorXd d = ldlt.vectorD().cwiseMax(0.0).cwiseSqrt();
    Eigen::MatrixXd F = ldlt.transpositionsP().transpose() * (L * d.asDiagonal());
    // Accept only when the factor reproduces M to working accuracy (LDL^T of a semidefinite
    // matrix can lose accuracy; the eigen-decomposition below cannot).
    if ((F * F.transpose() - sym).cwiseAbs().maxCoeff() <= 1e-10 * scale) return F;
  }
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(sym);
  const Eigen::VectorXd s = eig.eigenvalues().cwiseMax(0.0).cwiseSqrt();
  return eig.eigenvectors() * s.asDiagonal();
}

Trajectory Simulate(const Model& model, const SimulationOptions& options, Rng& rng) {
  return Simulate(model, TimeSeries(0, 0), options, rng);
}

// With a cross-covariance S, (w_k, v_k) is drawn at once from a factor of [[Q, S], [S^T, R]] (n + m normals
// per step); without, w_k and v_k from their own factors as before (the same draws as earlier versions).
Trajectory Simulate(const Model& model, const TimeSeries& g, const SimulationOptions& options, Rng& rng) {
  const int T = model.ResolveSteps(options.steps);
  RequireKnownInput(model, g, T);
  const Eigen::Index n = model.state_dim(), m = model.meas_dim();
  Trajectory tr;
  tr.x.resize(T + 1, n);
  tr.y.resize(T, m);
  Eigen::VectorXd x = model.m0() + PsdFactor(model.P0()) * rng.Normal(n);
  tr.x.row(0) = x.transpose();
  if (!x.allFinite()) throw NumericalError("simulate: the initial state x_0 is not finite (P0 overflows)");
  // Factors are cached per step object: a time-invariant model factors Q and R once.
  StepPtr cached;
  Eigen::MatrixXd Fw, Fv, Fj;
  Eigen::VectorXd next(n), v(m);
  for (int k = 1; k <= T; ++k) {
    StepPtr s = model.step(k);
    if (s != cached) {
      if (s->has_cross_covariance()) {
        Eigen::MatrixXd joint(n + m, n + m);
        joint << s->Q, s->S, s->S.transpose(), s->R;
        Fj = PsdFactor(joint);
      } else {
        Fw = s->B.size() > 0 ? Eigen::MatrixXd(s->B * PsdFactor(s->U)) : PsdFactor(s->Q);
        Eigen::LLT<Eigen::MatrixXd> llt(s->R);
        if (llt.info() != Eigen::Success) throw NumericalError("R: Cholesky factorization failed");
        Fv = llt.matrixL();
      }
      cached = s;
    }
    const KnownInputTerms input = KnownInputAt(*s, g, k);
    next.noalias() = s->A * x;
    if (s->has_cross_covariance()) {
      const Eigen::VectorXd wv = Fj * rng.Normal(n + m);
      next += wv.head(n);
      v = wv.tail(m);
    } else {
      next.noalias() += Fw * rng.Normal(Fw.cols());
    }
    if (input.state.size() > 0) next += input.state;
    x.swap(next);
    tr.x.row(k) = x.transpose();
    if (!s->has_cross_covariance()) v.noalias() = Fv * rng.Normal(m);
    if (input.measurement.size() > 0) v += input.measurement;
    tr.y.row(k - 1) = (s->C * x + v).transpose();
    if (!tr.x.row(k).allFinite() || !tr.y.row(k - 1).allFinite()) {
      throw NumericalError("simulate: the trajectory is not finite at step " + std::to_string(k) + " of " +
                           std::to_string(T) + " (the state overflows: the model diverges; simulate fewer steps)");
    }
    if (options.progress) options.progress(k, T);
  }
  return tr;
}

Trajectory Simulate(const Model& model, const SimulationOptions& options) {
  Rng rng(options.seed);
  return Simulate(model, options, rng);
}

Trajectory Simulate(const Model& model, const TimeSeries& g, const SimulationOptions& options) {
  Rng rng(options.seed);
  return Simulate(model, g, options, rng);
}

std::vector<Trajectory> SimulateBatch(const Model& model, int runs, const SimulationOptions& options) {
  if (runs < 0) throw Error("runs: expected a non-negative number of runs, got " + std::to_string(runs));
  std::vector<Trajectory> out;
  out.reserve(static_cast<size_t>(runs));
  for (int i = 0; i < runs; ++i) {
    Rng rng(Rng::StreamSeed(options.seed, static_cast<std::uint64_t>(i)));
    out.push_back(Simulate(model, options, rng));
  }
  return out;
}

}  // namespace kfx
