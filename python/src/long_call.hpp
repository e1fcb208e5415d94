#pragma once
// Long calls from Python (docs/python.md, "Large models"): the C++ work runs with the GIL released, and
// the library's progress hook (kfx::ProgressCallback, include/kfx/progress.hpp) becomes the way back
// into Python: at most every 0.05 s (by the clock, not per step) it takes the GIL, runs Python's signal
// handlers (PyErr_CheckSignals: Ctrl-C becomes KeyboardInterrupt) and calls the user's progress(done,
// total). A Python exception from either is kept, the C++ computation is unwound by the dedicated
// exception Interrupted, and the kept exception is raised in Python once the GIL is back.
//
//   LongCall call(progress);              // GIL held: progress is None or a callable
//   options.progress = call.callback();   // inputs already converted to Eigen (GIL held)
//   Result r = call.Run([&] { return Compute(..., options); });  // GIL released inside
#include <chrono>
#include <optional>
#include <utility>

#include "bindings.hpp"
#include "kfx/progress.hpp"

namespace kfx::python {

/// Thrown through the C++ library by LongCall's callback to stop a computation. Not derived from
/// std::exception, so that no catch clause of the library (they catch kfx::Error, kfx::NumericalError)
/// takes it for a failure of its own.
struct Interrupted {};

class LongCall {
 public:
  /// progress: None, or a callable progress(done, total) (e.g. a tqdm bar's update wrapped by the
  /// caller); it must be called with the GIL held (as bindings are).
  explicit LongCall(py::object progress = py::none());
  LongCall(const LongCall&) = delete;
  LongCall& operator=(const LongCall&) = delete;

  /// The hook to put in the computation's options; valid while this LongCall lives. Called without the GIL.
  ProgressCallback callback();

  /// f() with the GIL released; a Python exception raised by the callback is raised again here.
  template <typename F>
  auto Run(F&& f) -> decltype(f()) {
    try {
      py::gil_scoped_release release;
      return std::forward<F>(f)();
    } catch (const Interrupted&) {
      RaisePending();  // the GIL is held again here
    }
  }

  /// The minimum time between two calls into Python from the callback.
  static constexpr std::chrono::milliseconds kPeriod{50};

 private:
  void Poll(long done, long total);
  [[noreturn]] void RaisePending();

  py::object progress_;
  std::chrono::steady_clock::time_point next_;
  std::optional<py::error_already_set> pending_;
};

/// The progress argument of every long call: documented once.
inline constexpr const char* kProgressDoc =
    " progress: None or a callable progress(done, total), called at most every 0.05 s and at the end "
    "(e.g. a tqdm bar: lambda d, t: bar.update(d - bar.n)); an exception it raises stops the call. "
    "The GIL is released during the computation, and Ctrl-C stops it with KeyboardInterrupt.";

}  // namespace kfx::python
