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

}  // namespace kfx::detail
