// Long calls from Python: the GIL released around the C++ work, Ctrl-C and the user's progress
// callback through the library's progress hook (long_call.hpp).
#include "long_call.hpp"

#include <Python.h>

#include <string>

#include "kfx/error.hpp"

namespace kfx::python {

LongCall::LongCall(py::object progress)
    : progress_(std::move(progress)), next_(std::chrono::steady_clock::now() + kPeriod) {
  if (!progress_.is_none() && !PyCallable_Check(progress_.ptr())) {
    throw Error("progress: expected None or a callable progress(done, total), got " +
                py::str(py::type::of(progress_)).cast<std::string>());
  }
}

ProgressCallback LongCall::callback() {
  return [this](long done, long total) { Poll(done, total); };
}

void LongCall::Poll(long done, long total) {
  const auto now = std::chrono::steady_clock::now();
  // The last call (done == total) always reaches the user's callback, so that a bar ends full.
  const bool last = done >= total && !progress_.is_none();
  if (now < next_ && !last) return;
  next_ = now + kPeriod;
  py::gil_scoped_acquire acquire;
  try {
    if (PyErr_CheckSignals() != 0) throw py::error_already_set();
    if (!progress_.is_none()) progress_(done, total);
  } catch (py::error_already_set& e) {
    pending_.emplace(std::move(e));
    throw Interrupted{};
  }
}

void LongCall::RaisePending() {
  if (!pending_) throw Error("internal: a long call was interrupted without a Python exception");
  py::error_already_set e = std::move(*pending_);
  pending_.reset();
  throw e;
}

}  // namespace kfx::python
