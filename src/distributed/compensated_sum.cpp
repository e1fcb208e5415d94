// The compensated (double-double) sums that make the distributed results independent of the number of
// ranks: the reduction operator and the accumulation of one value (include/kfx/distributed.hpp).
#include "kfx/distributed.hpp"

#include "distributed/compensated_sum.hpp"

namespace kfx {

using detail::TwoSum;
using Eigen::Index;

void CompensatedAdd(const double* in, double* inout, Index pairs) {
  for (Index j = 0; j < pairs; ++j) {
    double s, e;
    TwoSum(in[2 * j], inout[2 * j], &s, &e);
    e += in[2 * j + 1] + inout[2 * j + 1];
    inout[2 * j] = s + e;  // renormalize (fast two-sum: |s| >= |e|)
    inout[2 * j + 1] = e - (inout[2 * j] - s);
  }
}

void CompensatedAccumulate(double value, double* pair) {
  double s, e;
  TwoSum(pair[0], value, &s, &e);
  e += pair[1];
  pair[0] = s + e;
  pair[1] = e - (pair[0] - s);
}

}  // namespace kfx
