#pragma once
// Private: the rounding floor of a fixed-point iteration (docs/robustness.md, class 15). An iteration
// that converges geometrically has relative changes c_k that shrink like rho^k (monotone, or with a
// decreasing envelope when rho is complex); once the iterate is exact to rounding, c_k stops
// shrinking and wanders at a level set by the arithmetic, which depends on the BLAS kernel (1.49e-10
// on one machine, 7.6e-11 on another, for the same problem). A tolerance below that level is never
// met. StagnationDetector recognizes the floor from the changes alone: over the last 2W changes
// (W = kWindow),
//   (a) no progress: the smallest change of the second half is at least half the smallest of the
//       first half, and the largest of the second half at least 0.9 times the largest of the first
//       (a geometric iteration shrinks its envelope by rho^W over W steps: by more than 10% for every
//       rho < 0.9979, so a slowly converging iteration, e.g. rho = 0.9956 in the paper-000 spatial
//       example, is not taken for a floor), and
//   (b) the change went up on at least a quarter of the steps (rounding noise; a converging
//       iteration goes down on most steps even when it oscillates), and
//   (c) the changes are small (the largest of the window <= kMaxFloor): a floor of rounding, not
//       an iteration that stalls far from its fixed point.
// The floor reported is the largest change of the second half: a tolerance at that level would
// have been met on every one of its steps.
#include <algorithm>
#include <cmath>
#include <deque>

namespace kfx::detail {

class StagnationDetector {
 public:
  static constexpr int kWindow = 50;
  static constexpr double kMaxFloor = 1e-6;

  /// Records the relative change of step k; true once the changes have reached their floor.
  bool Observe(double change) {
    if (!std::isfinite(change)) {
      changes_.clear();
      return false;
    }
    changes_.push_back(change);
    if (changes_.size() > 2 * kWindow) changes_.pop_front();
    if (changes_.size() < 2 * kWindow) return false;
    double min_first = changes_[0], min_second = changes_[kWindow], max_all = 0.0, max_first = 0.0, max_second = 0.0;
    int ups = 0;
    for (std::size_t i = 0; i < changes_.size(); ++i) {
      const double c = changes_[i];
      max_all = std::max(max_all, c);
      if (i < kWindow) {
        min_first = std::min(min_first, c);
        max_first = std::max(max_first, c);
      } else {
        min_second = std::min(min_second, c);
        max_second = std::max(max_second, c);
      }
      if (i > 0 && c > changes_[i - 1]) ++ups;
    }
    floor_ = max_second;
    return min_second >= 0.5 * min_first && max_second >= 0.9 * max_first && ups >= kWindow / 2 && max_all <= kMaxFloor;
  }
  /// The level of the changes at the floor (valid after Observe returned true).
  double floor() const { return floor_; }

 private:
  std::deque<double> changes_;
  double floor_ = 0.0;
};

/// The steady-state switch of the running filters (RunFilter's fast path, RunCoupledFilter's steady
/// block-diagonal filter): after each full step, Observe(|P_k - P_{k-1}|_F, |P_k|_F); true once the
/// relative change is at most the tolerance, or once the changes have reached their rounding floor
/// (a tolerance below the floor would never be met). Reset() after a step that may not switch (a
/// missing measurement): the changes before it say nothing about the recursion after it.
class SteadyStateSwitch {
 public:
  explicit SteadyStateSwitch(double tolerance) : tolerance_(tolerance) {}
  bool Observe(double change, double size) {
    const double relative = size > 0 ? change / size : change;
    if (relative <= tolerance_) return true;
    return floor_.Observe(relative);
  }
  void Reset() { floor_ = StagnationDetector(); }

 private:
  double tolerance_;
  StagnationDetector floor_;
};

}  // namespace kfx::detail
