// Steady state of the block-diagonal and banded filters (004 eq. (19), Prop. 2.1), the constants and
// bounds of Prop. 2.2 (Appendix A.2), and the exact reduction for identical subsystems (Sec. 3.1).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>
#include <vector>

#include "base/lapack_eigen.hpp"
#include "base/stagnation.hpp"
#include "kfx/block_diagonal.hpp"
#include "kfx/error.hpp"
#include "kfx/performance.hpp"
#include "kfx/riccati.hpp"
#include "kfx/simulation.hpp"
#include "kfx/validation.hpp"

namespace kfx {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// The steady-state iterations stop at their rounding floor when it lies above the tolerance (the
// floor depends on the BLAS kernel; docs/robustness.md, class 15).
void ConvergedAtFloor(const detail::StagnationDetector& floor, const SteadyStateOptions& options, Summary* sum) {
  sum->termination = Termination::kConverged;
  sum->message = "converged to the rounding floor: the relative change stagnated at " + FormatNumber(floor.floor()) +
                 " (tolerance " + FormatNumber(options.tolerance) + ")";
  sum->SetDetail("rounding_floor", FormatNumber(floor.floor()));
}

double Norm2(const MatrixXd& m) {
  if (m.size() == 0) return 0.0;
  return Eigen::JacobiSVD<MatrixXd>(m).singularValues()(0);
}

// cond_2 of the (unit-column) eigenvector matrix of a small real matrix: the Bauer-Fike constant.
double EigenvectorCondition(const MatrixXd& A) {
  Eigen::VectorXcd values;
  Eigen::MatrixXcd vectors;
  if (!detail::EigenDecompose(A, &values, &vectors)) return kInf;
  return detail::ConditionNumber(vectors);
}

// ||(I - B (x) A)^{-1}||_2: the norm, induced by the Frobenius norm, of the inverse of the Stein
// operator X -> X - A X B^T on c x c matrices (c^2 x c^2; the subsystems are small).
double SteinInverseNorm(const MatrixXd& A, const MatrixXd& B) {
  const Index c = A.rows();
  MatrixXd K(c * c, c * c);
  for (Index j = 0; j < c; ++j)
    for (Index l = 0; l < c; ++l) K.block(j * c, l * c, c, c) = B(j, l) * A;
  const VectorXd sv = Eigen::JacobiSVD<MatrixXd>(MatrixXd::Identity(c * c, c * c) - K).singularValues();
  const double smin = sv(sv.size() - 1);
  return smin > 0 ? 1.0 / smin : kInf;
}

// P - P H^T (H P H^T + R)^{-1} H P, and the gain P H^T (H P H^T + R)^{-1}.
void Posterior(const MatrixXd& P, const MatrixXd& H, const MatrixXd& R, MatrixXd* post, MatrixXd* gain) {
  const MatrixXd HP = H * P;
  Eigen::LLT<MatrixXd> llt(HP * H.transpose() + R);
  if (llt.info() != Eigen::Success) throw NumericalError("H P H^T + R: not positive definite");
  const MatrixXd Kt = llt.solve(HP);
  if (post) {
    *post = P - Kt.transpose() * HP;
    Symmetrize(*post);
  }
  if (gain) *gain = Kt.transpose();
}

// A failed inner DARE, carried from deep inside an analysis to its Summary (Analyze below).
struct InnerFailure {
  Summary summary;
};

DareSolution Dare(const MatrixXd& F, const MatrixXd& H, const MatrixXd& Q, const MatrixXd& R, const std::string& what) {
  DareSolution sol = SolveFilterDare(F, H, Q, R);
  if (!sol.summary.ok()) {
    sol.summary.computation = what;
    throw InnerFailure{sol.summary};
  }
  return sol;
}

// Runs an analysis and fills its Summary: kConverged unless body() set another termination; the
// termination of a failed inner DARE; kLostDefiniteness when a covariance step throws NumericalError.
template <typename Body>
void Analyze(const char* computation, const char* method, Summary* summary, const Body& body) {
  const auto start = std::chrono::steady_clock::now();
  summary->computation = computation;
  summary->method = method;
  summary->termination = Termination::kConverged;
  try {
    body();
  } catch (const InnerFailure& failure) {
    AdoptOutcome(failure.summary, summary);
  } catch (const NumericalError& e) {
    summary->termination = Termination::kLostDefiniteness;
    summary->message = e.what();
  }
  summary->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

bool SteadyStateOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  if (max_iterations < 1) return fail("max_iterations: expected >= 1, got " + std::to_string(max_iterations));
  if (!(tolerance > 0 && tolerance <= 1e-2)) return fail("tolerance: expected in (0, 1e-2]");
  return true;
}

BlockDiagonalSteadyState SolveBlockDiagonalSteadyState(const CoupledStep& s, const SteadyStateOptions& options) {
  std::string why;
  if (!options.IsValid(&why)) throw Error("options." + why);
  ValidateCoupledStep(s, s.n(), s.c(), s.d(), s.r());
  BlockDiagonalSteadyState out;
  Summary& sum = out.summary;
  // From P~_{0|0} = 0 the sequence is non-decreasing (proof of Prop. 2.1), so it cannot oscillate.
  MatrixXd P = MatrixXd::Zero(s.c(), s.n() * s.c());
  Analyze("block-diagonal steady state", "iteration of eq. (19) from 0", &sum, [&] {
    sum.termination = Termination::kNotConverged;
    detail::StagnationDetector floor;
    for (int it = 1; it <= options.max_iterations; ++it) {
      BlockDiagonalCovarianceStep st = BlockDiagonalCovarianceUpdate(s, P);
      const double change = (st.P_filt - P).norm(), size = st.P_filt.norm();
      sum.iterations = it;
      sum.relative_change = size > 0 ? change / size : change;
      P = std::move(st.P_filt);
      out.gain = std::move(st.gain);
      // The norms overflow before the entries do: a growing covariance must not read as a zero change.
      if (!std::isfinite(size) || !std::isfinite(change)) {
        sum.termination = Termination::kUnstable;
        sum.message = "the covariance grows without bound (no steady state: e.g. an unstable mode is not measured)";
        return;
      }
      if (options.progress) options.progress(it, options.max_iterations);
      if (sum.relative_change <= options.tolerance) {
        sum.termination = Termination::kConverged;
        return;
      }
      if (floor.Observe(sum.relative_change)) return ConvergedAtFloor(floor, options, &sum);
    }
    sum.message = "maximum iterations reached";
  });
  out.P_filt = std::move(P);
  return out;
}

BandedSteadyState SolveBandedSteadyState(const CoupledStep& s) {
  ValidateCoupledStep(s, s.n(), s.c(), s.d(), s.r());
  const Index n = s.n(), c = s.c(), d = s.d();
  const MatrixXd Q = BandedProcessNoise(s);
  BandedSteadyState out;
  out.P_filt.resize(c, n * c);
  out.K.resize(c, n * d);
  Analyze("banded steady state", "one DARE per subsystem", &out.summary, [&] {
    for (Index i = 0; i < n; ++i) {
      const DareSolution sol = Dare(s.F.middleCols(i * c, c), s.H.middleCols(i * c, c), Q.middleCols(i * c, c),
                                    s.R.middleCols(i * d, d), "banded DARE (block " + std::to_string(i) + ")");
      out.P_filt.middleCols(i * c, c) = sol.P_filt;
      out.K.middleCols(i * d, d) = sol.filter_gain;
    }
  });
  return out;
}

namespace {

// Prop. 2.2 (ComputeProposition22); a failed DARE is thrown as InnerFailure.
void Proposition22Constants(const CoupledStep& s, Proposition22& p) {
  const Index n = s.n(), c = s.c(), d = s.d(), r = s.r();
  for (VectorXd* v :
       {&p.alpha1, &p.alpha2, &p.alpha3, &p.alpha4, &p.alpha5, &p.epsilon, &p.bauer_fike, &p.spectral_radius,
        &p.part1_bound, &p.lyapunov_norm, &p.predictor_lyapunov_norm, &p.predictor_norm, &p.part1_corrected_bound}) {
    v->resize(n);
  }
  p.part1_applies.assign(static_cast<size_t>(n), false);
  p.part1_corrected_applies.assign(static_cast<size_t>(n), false);
  std::vector<MatrixXd> predictors;  // distinct A_p^(i), for the pairwise Stein norms of part (2)
  // C of eq. (20): C_{k,1} of one block-diagonal step from the banded filter's steady state.
  const BandedSteadyState banded = SolveBandedSteadyState(s);
  if (!banded.summary.ok()) throw InnerFailure{banded.summary};
  p.C = r > 0 ? BlockDiagonalCovarianceUpdate(s, banded.P_filt).gain.C1 : MatrixXd(0, 0);
  for (Index i = 0; i < n; ++i) {
    const MatrixXd F = s.F.middleCols(i * c, c), H = s.H.middleCols(i * c, c), V = s.V.middleCols(i * c, c),
                   R = s.R.middleCols(i * d, d);
    const DareSolution sol = Dare(F, H, V, R, "DARE of P_-(V) (block " + std::to_string(i) + ")");
    const MatrixXd& Pm = sol.P_pred;
    const MatrixXd Fc = (MatrixXd::Identity(c, c) - sol.filter_gain * H) * F;
    const double rho = SpectralRadius(Fc);
    p.spectral_radius(i) = rho;
    p.alpha1(i) = 1.0 / (1.0 - rho * rho);
    p.alpha2(i) = Norm2(Fc);
    const MatrixXd RinvH = Eigen::LLT<MatrixXd>(R).solve(H);
    p.alpha3(i) = Norm2((MatrixXd::Identity(c, c) + Pm * H.transpose() * RinvH).inverse());
    const MatrixXd SinvH = Eigen::LLT<MatrixXd>(H * Pm * H.transpose() + R).solve(H);
    p.alpha4(i) = Norm2(H.transpose() * SinvH * F);
    p.alpha5(i) = Norm2(H.transpose() * SinvH);
    p.bauer_fike(i) = EigenvectorCondition(Fc);
    const MatrixXd Gi = s.G.middleRows(i * c, c);
    p.epsilon(i) = r > 0 ? (Gi * p.C * Gi.transpose()).norm() : 0.0;
    const double a34e = p.alpha3(i) * p.alpha4(i) * p.epsilon(i);
    const double q = p.alpha1(i) * (2 * p.alpha2(i) + a34e) * a34e;
    const bool applies = q < 1 && rho + p.bauer_fike(i) * a34e < 1;
    p.part1_applies[static_cast<size_t>(i)] = applies;
    p.part1_bound(i) = applies ? p.alpha1(i) * p.alpha2(i) * p.alpha2(i) * p.epsilon(i) / (1 - q) : kInf;
    // Corrected (docs/papers/004.md): exact Stein-operator norm, forcing through I - K H.
    const MatrixXd Ap = F * (MatrixXd::Identity(c, c) - sol.filter_gain * H);
    p.lyapunov_norm(i) = SteinInverseNorm(Fc, Fc);
    p.predictor_lyapunov_norm(i) = SteinInverseNorm(Ap, Ap);
    p.predictor_norm(i) = Norm2(Ap);
    const double qc = p.lyapunov_norm(i) * (2 * Fc.norm() + a34e) * a34e;
    const bool corrected_applies = qc < 1 && rho + p.bauer_fike(i) * a34e < 1;
    p.part1_corrected_applies[static_cast<size_t>(i)] = corrected_applies;
    p.part1_corrected_bound(i) =
        corrected_applies ? p.lyapunov_norm(i) * p.alpha3(i) * p.alpha3(i) * p.epsilon(i) / (1 - qc) : kInf;
    bool seen = false;
    for (const MatrixXd& m : predictors) seen = seen || m == Ap;
    if (!seen) predictors.push_back(Ap);
  }
  // eta = ||G U G^T||_F = sqrt(tr((U G^T G)^2)) in O(n c r^2).
  if (r > 0) {
    const MatrixXd UGtG = s.U * (s.G.transpose() * s.G);
    p.eta = std::sqrt(std::max(0.0, (UGtG * UGtG).trace()));
  }
  const double a1 = p.alpha1.maxCoeff(), a2 = p.alpha2.maxCoeff(), a3 = p.alpha3.maxCoeff(), a4 = p.alpha4.maxCoeff(),
               a5 = p.alpha5.maxCoeff();
  const double disc = 4 * a1 * a1 * a2 * a2 * a5 * p.eta;
  p.part2_applies = disc < 1;
  p.part2_simple_bound = 2 * a1 * p.eta;
  if (!p.part2_applies) {
    p.part2_bound = kInf;
  } else if (a2 * a5 == 0) {
    p.part2_bound = a1 * p.eta;  // the quadratic term vanishes
  } else {
    p.part2_bound = (1 - std::sqrt(1 - disc)) / (2 * a1 * a2 * a2 * a5);
  }
  p.closed_loop_bound = a3 * a4 * p.part2_bound;
  // Corrected part (2): the linearized operator Z -> Z - F D{(I - K H) Z (I - K H)^T} F^T (block
  // filter) or Z -> Z - A_p Z A_p^T (full filter); on block (i, j) the latter inverts with norm
  // ||(I - A_p^(j) (x) A_p^(i))^{-1}||, the former with that for i = j and 1 otherwise.
  double a1c = 1.0;
  for (const MatrixXd& Ai : predictors)
    for (const MatrixXd& Aj : predictors) a1c = std::max(a1c, SteinInverseNorm(Ai, Aj));
  const double a2c = p.predictor_norm.maxCoeff();
  const double ac = a1c * p.eta, bc = a1c * a2c * a2c * a5;
  p.part2_corrected_applies = 4 * ac * bc < 1;
  if (!p.part2_corrected_applies) {
    p.part2_corrected_bound = kInf;
  } else if (bc == 0) {
    p.part2_corrected_bound = ac;
  } else {
    p.part2_corrected_bound = (1 - std::sqrt(1 - 4 * ac * bc)) / (2 * bc);
  }
  p.closed_loop_corrected_bound = a3 * a4 * p.part2_corrected_bound;
}

}  // namespace

Proposition22 ComputeProposition22(const CoupledStep& s) {
  ValidateCoupledStep(s, s.n(), s.c(), s.d(), s.r());
  Proposition22 p;
  Analyze("Proposition 2.2", "per-subsystem DAREs and Stein-operator norms", &p.summary,
          [&] { Proposition22Constants(s, p); });
  return p;
}

// ---- Identical subsystems --------------------------------------------------------------------------

MatrixXd KroneckerStructured::Dense() const {
  const Index a = X.rows(), b = X.cols();
  MatrixXd D(n * a, n * b);
  for (Index i = 0; i < n; ++i)
    for (Index j = 0; j < n; ++j) D.block(i * a, j * b, a, b) = (i == j) ? MatrixXd(X + Y) : Y;
  return D;
}

MatrixXd KroneckerStructured::DiagonalBlock() const { return X + Y; }
MatrixXd KroneckerStructured::MeanMode() const { return X + static_cast<double>(n) * Y; }

double FrobeniusDistance(const KroneckerStructured& a, const KroneckerStructured& b) {
  if (a.n != b.n || a.X.rows() != b.X.rows() || a.X.cols() != b.X.cols() || a.Y.rows() != b.Y.rows() ||
      a.Y.cols() != b.Y.cols()) {
    throw Error("b: expected the same n and block shapes as a");
  }
  const MatrixXd dX = a.X - b.X, dY = a.Y - b.Y;
  const double nn = static_cast<double>(a.n);
  return std::sqrt(nn * (dX + dY).squaredNorm() + nn * (nn - 1) * dY.squaredNorm());
}

namespace {

void ValidateIdentical(const IdenticalSubsystems& sys) {
  RequireSquare("F", sys.F);
  const Index c = sys.F.rows();
  RequireShape("H", sys.H, -1, c);
  RequireShape("V", sys.V, c, c);
  RequireShape("R", sys.R, sys.H.rows(), sys.H.rows());
  RequireShape("g", sys.g, c, -1);
  RequireShape("U", sys.U, sys.g.cols(), sys.g.cols());
  RequireFinite("F", sys.F);
  RequireFinite("H", sys.H);
  RequireFinite("g", sys.g);
  RequirePositiveSemidefinite("V", sys.V);
  RequirePositiveDefinite("R", sys.R);
  RequirePositiveSemidefinite("U", sys.U);
}

// Stationary true error of the constant gain K on (F, H, Q, R), through the engine; empty if the
// filter is unstable there.
MatrixXd TrueError(const MatrixXd& F, const MatrixXd& H, const MatrixXd& Q, const MatrixXd& R, const MatrixXd& K) {
  const ModelStep step = MakeStep(F, H, Q, R);
  const Model truth(step, VectorXd::Zero(F.rows()), MatrixXd::Identity(F.rows(), F.rows()));
  const StationaryPerformance perf =
      ExactStationaryPerformance(truth, ConstantGainAsLinearFilter(step, K, VectorXd::Zero(F.rows())));
  return perf.summary.ok() ? perf.error_cov : MatrixXd();
}

KroneckerStructured FromModes(Index n, const MatrixXd& complement, const MatrixXd& mean) {
  KroneckerStructured k;
  k.n = n;
  if (complement.size() == 0 || mean.size() == 0) return k;
  k.X = complement;
  k.Y = (mean - complement) / static_cast<double>(n);
  return k;
}

}  // namespace

namespace {

// The block-diagonal steady state of identical subsystems (eq. (19) on the two modes): X, the gains on
// the complement and the mean mode. Fills `sum`.
void IdenticalBlockSteadyState(const IdenticalSubsystems& sys, double nn, const SteadyStateOptions& options,
                               MatrixXd* X_out, MatrixXd* Kc, MatrixXd* Km, Summary* sum) {
  const MatrixXd gUg = sys.g * sys.U * sys.g.transpose();
  // X <- D{posterior}; on the modes the posterior of L = F X F^T + V is post(L) on the complement and
  // post(L + n g U g^T) on the mean mode, and its diagonal block is post(L) + (post(L + n gUg^T) - post(L)) / n.
  MatrixXd X = MatrixXd::Zero(sys.F.rows(), sys.F.rows());
  Analyze("block-diagonal steady state", "iteration of eq. (19) on the two modes", sum, [&] {
    sum->termination = Termination::kNotConverged;
    detail::StagnationDetector floor;
    for (int it = 1; it <= options.max_iterations; ++it) {
      MatrixXd L = sys.F * X * sys.F.transpose() + sys.V;
      Symmetrize(L);
      MatrixXd pc, pm;
      Posterior(L, sys.H, sys.R, &pc, Kc);
      Posterior(L + nn * gUg, sys.H, sys.R, &pm, Km);
      MatrixXd Xn = pc + (pm - pc) / nn;
      Symmetrize(Xn);
      const double size = Xn.norm(), change = (Xn - X).norm();
      sum->iterations = it;
      sum->relative_change = size > 0 ? change / size : change;
      X = std::move(Xn);
      // The norms overflow before the entries do: a growing covariance must not read as a zero change.
      if (!std::isfinite(size) || !std::isfinite(change)) {
        sum->termination = Termination::kUnstable;
        sum->message = "the covariance grows without bound (no steady state: e.g. an unstable mode is not measured)";
        return;
      }
      if (options.progress) options.progress(it, options.max_iterations);
      if (sum->relative_change <= options.tolerance) {
        sum->termination = Termination::kConverged;
        return;
      }
      if (floor.Observe(sum->relative_change)) return ConvergedAtFloor(floor, options, sum);
    }
    sum->message = "maximum iterations reached";
  });
  *X_out = std::move(X);
}

}  // namespace

IdenticalAnalysis AnalyzeIdenticalSubsystems(const IdenticalSubsystems& sys, Index n,
                                             const SteadyStateOptions& options) {
  ValidateIdentical(sys);
  if (n < 1) throw Error("n: expected at least 1 subsystem, got " + std::to_string(n));
  std::string why;
  if (!options.IsValid(&why)) throw Error("options." + why);
  const double nn = static_cast<double>(n);
  const MatrixXd gUg = sys.g * sys.U * sys.g.transpose();
  const MatrixXd Qmean = sys.V + nn * gUg;  // process noise on the mean mode 1/sqrt(n)
  IdenticalAnalysis a;
  Analyze("identical-subsystem analysis", "reduction to two modes (004 Sec. 3.1)", &a.summary, [&] {
    // Full KF: the complement sees V, the mean mode V + n g U g^T.
    const DareSolution unc = Dare(sys.F, sys.H, sys.V, sys.R, "DARE of P_+(V)");
    const DareSolution mean = Dare(sys.F, sys.H, Qmean, sys.R, "DARE of the mean mode");
    a.uncoupled_P = FromModes(n, unc.P_filt, unc.P_filt);
    a.full_P = FromModes(n, unc.P_filt, mean.P_filt);
    a.full_gain = FromModes(n, unc.filter_gain, mean.filter_gain);
    // Banded: every block sees D{V + G U G^T} = V + g U g^T.
    const DareSolution band = Dare(sys.F, sys.H, sys.V + gUg, sys.R, "banded DARE");
    a.banded_P = FromModes(n, band.P_filt, band.P_filt);
    a.banded_gain = FromModes(n, band.filter_gain, band.filter_gain);
    MatrixXd X, Kc, Km;
    IdenticalBlockSteadyState(sys, nn, options, &X, &Kc, &Km, &a.block_summary);
    a.block_P = FromModes(n, X, X);
    a.block_gain = FromModes(n, Kc, Km);
    // True stationary errors, mode by mode, through the exact-performance engine.
    a.block_true = FromModes(n, TrueError(sys.F, sys.H, sys.V, sys.R, Kc), TrueError(sys.F, sys.H, Qmean, sys.R, Km));
    a.banded_true = FromModes(n, TrueError(sys.F, sys.H, sys.V, sys.R, band.filter_gain),
                              TrueError(sys.F, sys.H, Qmean, sys.R, band.filter_gain));
    a.full_true = FromModes(n, TrueError(sys.F, sys.H, sys.V, sys.R, unc.filter_gain),
                            TrueError(sys.F, sys.H, Qmean, sys.R, mean.filter_gain));
  });
  return a;
}

double UnknownInputSpectralRadius(const IdenticalSubsystems& sys) {
  ValidateIdentical(sys);
  const MatrixXd Hg = sys.H * sys.g;
  if (Hg.rows() != Hg.cols()) {
    throw Error("g: expected as many coupling inputs as measurements per subsystem (d = r), got d = " +
                std::to_string(Hg.rows()) + ", r = " + std::to_string(Hg.cols()));
  }
  Eigen::FullPivLU<MatrixXd> lu(Hg);
  if (!lu.isInvertible()) throw Error("g: expected H g to be invertible");
  const Index c = sys.F.rows();
  const MatrixXd A = (MatrixXd::Identity(c, c) - sys.g * lu.solve(sys.H)) * sys.F;
  return SpectralRadius(A);
}

}  // namespace kfx
