#pragma once
#include <functional>

namespace kfx {
/// Called by long computations as progress(done, total), done increasing; may be empty.
/// It is also the cancellation hook: a callback may throw (the Python bindings throw to deliver
/// Ctrl-C), and the computation then unwinds and propagates the exception unchanged. Computations
/// call it between steps, so cancellation waits for the step under way to end.
using ProgressCallback = std::function<void(long done, long total)>;
}  // namespace kfx
