// A progress line on stderr for the long computations of the subcommands, shown only when stderr is a terminal.
#include "progress.hpp"

#include <unistd.h>

#include <cstdio>

namespace kfx::cli {

ProgressLine::ProgressLine(std::string label) : label_(std::move(label)), enabled_(isatty(STDERR_FILENO) == 1) {}

ProgressLine::~ProgressLine() { Finish(); }

ProgressCallback ProgressLine::callback() {
  if (!enabled_) return ProgressCallback();
  return [this](long done, long total) { Update(done, total); };
}

void ProgressLine::Update(long done, long total) {
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  if (shown_ && done < total && now - last_ < std::chrono::milliseconds(100)) return;
  last_ = now;
  shown_ = true;
  const double pct = total > 0 ? 100.0 * static_cast<double>(done) / static_cast<double>(total) : 0.0;
  std::fprintf(stderr, "\r%s: %ld/%ld (%.0f%%)", label_.c_str(), done, total, pct);
  std::fflush(stderr);
}

void ProgressLine::Finish() {
  if (enabled_ && shown_) {
    std::fprintf(stderr, "\r\033[K");
    std::fflush(stderr);
    shown_ = false;
  }
}

}  // namespace kfx::cli
