#pragma once
// Double-double arithmetic shared by the distributed sums (private to src/distributed/).

namespace kfx::detail {

// s + e = a + b exactly (Knuth's TwoSum).
inline void TwoSum(double a, double b, double* s, double* e) {
  *s = a + b;
  const double bb = *s - a;
  *e = (a - (*s - bb)) + (b - bb);
}

}  // namespace kfx::detail
