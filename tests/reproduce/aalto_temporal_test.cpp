// kfx reproduce aalto-temporal: the item keys are a contract (docs/papers/003.md).
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "kfx/reproduce.hpp"

namespace kfx {
namespace {

TEST(ReproduceAaltoTemporal, KeysAreTheContract) {
  const PaperReport r = Reproduce("aalto-temporal", ReproduceOptions{true, "", {}});
  std::vector<std::string> keys;
  for (const auto& it : r.items) keys.push_back(it.key);
  std::vector<std::string> expected;
  for (const std::string e : {"scalar", "osc_B0", "osc_noise", "rw_highsnr"}) {
    expected.push_back(e + ".trPc");
    for (const std::string n : {"1", "16", "1024"}) expected.push_back(e + ".err.n=" + n);
    if (e == "rw_highsnr") expected.push_back(e + ".err.n=16384");
    expected.push_back(e + ".rate");
    expected.push_back(e + ".bound_over_err.n=1024");
  }
  for (const std::string w : {"rough", "smooth"}) {
    expected.push_back("wave." + w + ".rate");
    expected.push_back("wave." + w + ".err.n=1024");
  }
  EXPECT_EQ(keys, expected);
  for (const auto& it : r.items) {
    EXPECT_TRUE(std::isfinite(it.value)) << it.key;
    if (it.key.find(".err.") != std::string::npos) {
      EXPECT_GT(it.value, 0.0) << it.key;
    }
    if (it.key.find("bound_over_err") != std::string::npos) {
      EXPECT_GT(it.value, 1.0) << it.key;
    }
  }
}

}  // namespace
}  // namespace kfx
