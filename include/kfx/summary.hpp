#pragma once
// How a computation ended: one Summary shape for every solver and long computation of kfx (the DARE,
// the Lyapunov equation, the stability certificate, the CARE, steady-state iterations, schedules,
// stationary analyses, bounds, Monte Carlo). docs/architecture.md, "Errors and outcomes":
//   invalid input          -> kfx::Error is thrown (never a Summary);
//   a numerical outcome    -> the result's Summary (no convergence, a singular equation, lost
//                             definiteness, an unstable system or filter, a failed inner solve);
//   an internal invariant  -> KFX_ASSERT.
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "kfx/enum_text.hpp"

namespace kfx {

/// How a computation ended. ok() only for kConverged.
enum class Termination {
  kConverged,         ///< success: an iteration met its tolerance, or a direct solve passed its checks
  kNotConverged,      ///< the iteration limit was reached first; the result is the last iterate
  kNotStabilizing,    ///< a Riccati solution was found but it is not the stabilizing one (or not PSD)
  kNotDetectable,     ///< (A, C) has an unobservable mode with |lambda| >= 1
  kNotStabilizable,   ///< (A, Q^{1/2}) has an unreachable mode on the unit circle
  kUnstable,          ///< no stationary value: the system or the filter is unstable (message says which)
  kSingular,          ///< the equation is singular (e.g. a Lyapunov equation with lambda_i lambda_j = 1)
  kLostDefiniteness,  ///< a covariance that must be positive definite is not (numerically)
  kUndecided,         ///< the computation could not decide (e.g. a certificate that neither proves nor refutes)
  kFailed,            ///< a breakdown: a LAPACK/SLICOT failure, non-finite numbers; see the message
};
/// "converged", "not_converged", "not_stabilizing", "not_detectable", "not_stabilizable", "unstable",
/// "singular", "lost_definiteness", "undecided", "failed" (the text of the CLI's JSON).
const char* ToString(Termination termination);
template <>
struct EnumValues<Termination> {
  static constexpr Termination kAll[] = {Termination::kConverged,       Termination::kNotConverged,
                                         Termination::kNotStabilizing,  Termination::kNotDetectable,
                                         Termination::kNotStabilizable, Termination::kUnstable,
                                         Termination::kSingular,        Termination::kLostDefiniteness,
                                         Termination::kUndecided,       Termination::kFailed};
};

struct Summary {
  /// What was computed, e.g. "filter DARE", "discrete Lyapunov equation" (the reports start with it).
  std::string computation;
  Termination termination = Termination::kFailed;
  /// One line: why it failed, or what was done (e.g. a fallback taken).
  std::string message;
  /// The algorithm that produced the result, e.g. "doubling", "SB03MD (Schur)", "joint Lyapunov equation".
  std::string method;
  /// Iterations or steps done (0 for a direct method).
  int iterations = 0;
  /// Relative residual of the equation solved, as each computation defines it (NaN: not computed).
  double relative_residual = std::numeric_limits<double>::quiet_NaN();
  /// An iteration's last relative change of its iterate (NaN: not an iteration).
  double relative_change = std::numeric_limits<double>::quiet_NaN();
  /// Wall-clock time of the computation.
  double seconds = 0.0;
  /// Further named facts specific to the computation, in the order they are listed by FullReport.
  std::vector<std::pair<std::string, std::string>> details;

  bool ok() const { return termination == Termination::kConverged; }
  /// For callers that cannot go on without this result: throws kfx::NumericalError
  /// ("<brief report>: <message>") unless ok().
  void RequireOk() const;
  /// Adds (or replaces) a named fact.
  void SetDetail(const std::string& key, std::string value);
  /// The value of a named fact, or "" if there is none.
  std::string Detail(const std::string& key) const;
  /// One line: "<computation>: <termination> by <method>, N iterations, relative residual r, t s".
  std::string BriefReport() const;
  /// A table of every field and detail, one per line.
  std::string FullReport() const;
};

/// For a computation that reports a failed inner computation in its own Summary: copies the inner
/// termination and sets the message to "<inner computation>: <inner message>".
void AdoptOutcome(const Summary& inner, Summary* outer);

/// "%.*g" of v (the number format of reports and messages).
std::string FormatNumber(double v, int precision = 3);

}  // namespace kfx
