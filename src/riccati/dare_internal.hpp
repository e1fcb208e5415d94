#pragma once
// Private to the DARE (dare.cpp): what each method hands to the common finishing step, and the
// failure diagnosis.
#include <Eigen/Dense>
#include <string>

#include "kfx/riccati.hpp"
#include "riccati/riccati_internal.hpp"

namespace kfx::detail {

/// What a method hands to Finalize (dare.cpp).
struct DareCandidate {
  Eigen::MatrixXd P;                               ///< empty if the method produced nothing usable.
  Termination termination = Termination::kFailed;  ///< kConverged if the method itself succeeded.
  std::string message;
  DareMethod method = DareMethod::kDoubling;
  int iterations = 0;
};

/// The structure-preserving doubling algorithm on the dual problem (dare_doubling.cpp).
/// Its n x n buffers come from *pool and go back to it (for the refinement and the certificate).
DareCandidate SolveDareByDoubling(const ConstRef& A, const ConstRef& C, const ConstRef& Q, const ConstRef& R,
                                  const DareOptions& options, MatrixPool* pool);

/// Why no acceptable DARE solution exists, by PBH rank tests (dare_diagnosis.cpp): found = true with
/// termination kNotDetectable or kNotStabilizable when a test applies.
struct DareDiagnosis {
  bool found = false;
  Termination termination = Termination::kFailed;
  std::string message;
};
DareDiagnosis DiagnoseDare(const ConstRef& A, const ConstRef& C, const ConstRef& Q);

/// The validated cross-term / descriptor problem shared by the generalized filter DARE
/// (dare_general.cpp) and the filter CARE (care.cpp).
struct GeneralProblem {
  Eigen::Index n = 0, m = 0;
  Eigen::MatrixXd S, E;  ///< filled in: S = 0 (n x m) and E = I when not given
  bool has_s = false, has_e = false;
  double e_rcond = 1.0;  ///< rcond_1(E) (1 without E)
};
/// Checks A, C, Q, R, S (0 x 0: none), E (0 x 0: identity) as include/kfx/riccati.hpp states for the
/// generalized SolveFilterDare; require_psd: also Q PSD, R PD and [[Q, S], [S^T, R]] PSD (named "S").
/// @throws kfx::Error naming the argument (dare_general.cpp).
GeneralProblem ValidateGeneralProblem(const ConstRef& A, const ConstRef& C, const ConstRef& Q, const ConstRef& R,
                                      const ConstRef& S, const ConstRef& E, bool require_psd);

}  // namespace kfx::detail
