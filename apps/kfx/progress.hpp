#pragma once
// A progress line on stderr, shown only when stderr is a terminal (never in logs or pipes).
#include <chrono>
#include <string>

#include "kfx/progress.hpp"

namespace kfx::cli {

class ProgressLine {
 public:
  explicit ProgressLine(std::string label);
  ~ProgressLine();
  /// A callback for the library's long computations.
  ProgressCallback callback();
  void Update(long done, long total);
  void Finish();

 private:
  std::string label_;
  bool enabled_;
  bool shown_ = false;
  std::chrono::steady_clock::time_point last_;
};

}  // namespace kfx::cli
