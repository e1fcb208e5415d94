#pragma once
// Test helper: "this call throws a kfx::Error whose message names X", in one place. Use it as
//   EXPECT_TRUE(ThrowsErrorNaming([&] { Model(bad, m0, P0); }, "Q"));
//   EXPECT_TRUE(ThrowsErrorStartingWith([&] { SolveFilterDare(A, C, Q, R); }, "A:"));
// so that a failure is reported at the caller's line, with the message that was (or was not) thrown.
#include <gtest/gtest.h>

#include <exception>
#include <string>
#include <vector>

#include "kfx/error.hpp"

namespace kfx::testing {

namespace detail {

// Runs `call`; succeeds iff it throws kfx::Error whose message starts with `prefix` (if not empty)
// and contains every one of `texts`.
template <typename F>
::testing::AssertionResult ThrowsErrorWith(F&& call, const std::string& prefix, const std::vector<std::string>& texts) {
  std::string expected;
  if (!prefix.empty()) expected += " starting with '" + prefix + "'";
  for (const std::string& t : texts) expected += " naming '" + t + "'";
  try {
    call();
  } catch (const Error& e) {
    const std::string what = e.what();
    if (!prefix.empty() && what.rfind(prefix, 0) != 0) {
      return ::testing::AssertionFailure() << "kfx::Error \"" << what << "\" does not start with '" << prefix << "'";
    }
    for (const std::string& t : texts) {
      if (what.find(t) == std::string::npos) {
        return ::testing::AssertionFailure() << "kfx::Error \"" << what << "\" does not name '" << t << "'";
      }
    }
    return ::testing::AssertionSuccess();
  } catch (const std::exception& e) {
    return ::testing::AssertionFailure() << "expected kfx::Error" << expected
                                         << "; got another exception: " << e.what();
  }
  return ::testing::AssertionFailure() << "no kfx::Error thrown; expected one" << expected;
}

}  // namespace detail

/// `call()` throws kfx::Error whose message contains `name` (and every one of `also`).
template <typename F>
::testing::AssertionResult ThrowsErrorNaming(F&& call, const std::string& name,
                                             const std::vector<std::string>& also = {}) {
  std::vector<std::string> texts{name};
  texts.insert(texts.end(), also.begin(), also.end());
  return detail::ThrowsErrorWith(call, "", texts);
}

/// `call()` throws kfx::Error whose message starts with `prefix` (and contains every one of `also`).
template <typename F>
::testing::AssertionResult ThrowsErrorStartingWith(F&& call, const std::string& prefix,
                                                   const std::vector<std::string>& also = {}) {
  return detail::ThrowsErrorWith(call, prefix, also);
}

}  // namespace kfx::testing
