#pragma once
#include <functional>

namespace kfx {
/// Called by long computations as progress(done, total); may be empty.
using ProgressCallback = std::function<void(long done, long total)>;
}  // namespace kfx
