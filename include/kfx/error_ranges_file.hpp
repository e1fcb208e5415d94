#pragma once
// The error-ranges file of `kfx mismatch --ranges` (docs/formats.md, "Error ranges"): element-wise
// bounds on the errors of a design model (paper 002, Sec. 6), read into kfx::ErrorRanges
// (include/kfx/mismatch.hpp).
#include <string>

#include "kfx/mismatch.hpp"
#include "kfx/model.hpp"

namespace kfx {

/// Reads an error-ranges file (JSON, docs/formats.md "Error ranges") for `design`.
/// @throws kfx::Error naming the file and field.
ErrorRanges LoadErrorRanges(const std::string& path, const ModelStep& design);

}  // namespace kfx
