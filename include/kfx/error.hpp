#pragma once
// Errors and internal assertions (three error tiers, docs/architecture.md "Errors and outcomes"):
//  1. bad input            -> throw kfx::Error (message names the argument and what was expected);
//  2. numerical outcomes   -> a status in the algorithm's Summary;
//  3. internal invariants  -> KFX_ASSERT (a bug in kfx, not in the caller's input).
#include <stdexcept>
#include <string>

namespace kfx {

/// Raised for invalid input: wrong dimensions, non-symmetric / indefinite covariances, NaN/Inf,
/// unreadable files, bad options. The message names the argument and what was expected.
class Error : public std::invalid_argument {
 public:
  explicit Error(const std::string& what) : std::invalid_argument(what) {}
};

/// Raised when an internal invariant of kfx fails (a bug in kfx).
class InternalError : public std::logic_error {
 public:
  explicit InternalError(const std::string& what) : std::logic_error(what) {}
};

namespace detail {
[[noreturn]] void AssertFail(const char* expr, const char* file, int line);
}  // namespace detail

}  // namespace kfx

#define KFX_ASSERT(cond) ((cond) ? static_cast<void>(0) : ::kfx::detail::AssertFail(#cond, __FILE__, __LINE__))

namespace kfx {
/// Raised when a computation breaks down numerically on valid input (e.g. an innovation
/// covariance that lost definiteness). Solvers with a Summary report such outcomes there instead.
class NumericalError : public std::runtime_error {
 public:
  explicit NumericalError(const std::string& what) : std::runtime_error(what) {}
};
}  // namespace kfx
