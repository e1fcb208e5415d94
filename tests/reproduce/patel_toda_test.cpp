// kfx reproduce patel-toda: the item keys are a contract (docs/papers/002.md).
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "kfx/reproduce.hpp"

namespace kfx {
namespace {

TEST(MismatchReproduce, PatelTodaPrintsTheTwelveRows) {
  const PaperReport r = Reproduce("patel-toda");
  const char* keys[12] = {"thm3.case1.pi3", "thm3.case1.least_upper",    "thm3.case2.pi3", "thm3.case2.least_upper",
                          "thm4.case1.pi4", "thm4.case1.greatest_lower", "thm4.case2.pi4", "thm4.case2.greatest_lower",
                          "thm5.pi5",       "thm5.least_upper",          "thm6.pi6",       "thm6.greatest_lower"};
  ASSERT_EQ(r.items.size(), 12u);
  for (size_t k = 0; k < 12; ++k) {
    const ReproduceItem& it = r.items[k];
    EXPECT_EQ(it.key, keys[k]);
    ASSERT_TRUE(it.published.has_value());
    EXPECT_TRUE(std::isfinite(it.value));
    // Every number that differs from the paper says why.
    if (it.status() == "differs") {
      EXPECT_FALSE(it.note.empty()) << it.key;
    }
  }
  // Upper bounds lie above the least upper bounds, lower bounds below the greatest lower bounds.
  for (size_t k = 0; k < 12; k += 2) {
    if (r.items[k].key.find("pi3") != std::string::npos || r.items[k].key.find("pi5") != std::string::npos) {
      EXPECT_GE(r.items[k].value, r.items[k + 1].value) << r.items[k].key;
    } else {
      EXPECT_LE(r.items[k].value, r.items[k + 1].value) << r.items[k].key;
    }
  }
}

}  // namespace
}  // namespace kfx
