#pragma once
// Shared by Model and LinearFilter: the matrices of step k of a schedule that is time-invariant
// (one stored step), a stored sequence (step k at index k - 1) or a callback (validated per call).
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "kfx/error.hpp"

namespace kfx::detail {

enum class ScheduleKind { kInvariant, kSequence, kFunction };

/// @param what "step" or "filter step", for the out-of-range message.
/// @param validate called on each step a callback returns, with the label "step k: ".
/// @throws kfx::Error if k is outside 1..horizon (horizon < 0: unbounded).
template <typename Step, typename Validate>
std::shared_ptr<const Step> StepAt(int k, ScheduleKind kind, int horizon,
                                   const std::vector<std::shared_ptr<const Step>>& stored,
                                   const std::function<Step(int)>& function, const Validate& validate,
                                   const char* what) {
  if (k < 1 || (horizon >= 0 && k > horizon)) {
    throw Error(std::string("k: expected a ") + what + " in 1.." +
                (horizon >= 0 ? std::to_string(horizon) : std::string("inf")) + ", got " + std::to_string(k));
  }
  switch (kind) {
    case ScheduleKind::kInvariant:
      return stored[0];
    case ScheduleKind::kSequence:
      return stored[static_cast<size_t>(k - 1)];
    case ScheduleKind::kFunction: {
      Step s = function(k);
      validate(s, "step " + std::to_string(k) + ": ");
      return std::make_shared<const Step>(std::move(s));
    }
  }
  KFX_ASSERT(false);
  return nullptr;
}

}  // namespace kfx::detail
