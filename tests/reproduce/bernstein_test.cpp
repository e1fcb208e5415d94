// kfx reproduce bernstein: the item keys are a contract (docs/papers/001.md).
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "kfx/reproduce.hpp"

namespace kfx {
namespace {

TEST(BernsteinReproduce, PrintsTheIssueKeysAndEveryRatioIsAtLeastOne) {
  ReproduceOptions o;
  o.quick = true;
  const PaperReport r = Reproduce("bernstein", o);
  std::vector<std::string> expected;
  for (const char* E : {"8", "16"}) {
    for (const char* est :
         {"reduced.onestep", "reduced.twostep_da", "reduced.twostep_f", "subspace.onestep", "subspace.twostep_da"}) {
      for (const char* K : {"10", "100", "500"}) {
        expected.push_back(std::string("sec5.ne=") + E + "." + est + ".k=" + K);
      }
    }
  }
  for (const char* E : {"4", "8"}) {
    for (const char* K : {"10", "100", "500"}) {
      expected.push_back(std::string("sec6.ne=") + E + ".subspace.onestep.k=" + K);
    }
  }
  ASSERT_EQ(r.items.size(), expected.size());
  for (size_t i = 0; i < expected.size(); ++i) {
    EXPECT_EQ(r.items[i].key, expected[i]);
    EXPECT_TRUE(std::isfinite(r.items[i].value)) << expected[i];
    EXPECT_GE(r.items[i].value, 1.0 - 1e-12) << expected[i];  // nothing beats the Kalman filter
    EXPECT_LT(r.items[i].value, 10.0) << expected[i];
  }
}

}  // namespace
}  // namespace kfx
