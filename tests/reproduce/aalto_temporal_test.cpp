// kfx reproduce aalto-temporal: the item keys are a contract (docs/papers/003.md), and every quick value is
// pinned.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "kfx/reproduce.hpp"
#include "support/reproduce_pins.hpp"

namespace kfx {
namespace {

using testing::ExpectMatchesPins;
using testing::kDirect;
using testing::PinnedItem;
using testing::QuickReport;

TEST(ReproduceAaltoTemporal, KeysAreTheContract) {
  const PaperReport& r = QuickReport("aalto-temporal");
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

// Table: `kfx reproduce aalto-temporal --quick --json` at cfd5102 (OpenBLAS 0.3.21 Haswell kernel, AMD EPYC,
// 2026-12-01); to regenerate it after a deliberate change, follow tests/support/reproduce_pins.hpp.
// Tolerances: kDirect (matrix exponentials, the Kalman-Bucy Hamiltonian exponential and finite recursions;
// the 1- and 2-state examples do not reach BLAS, spread 0). err(n) is a difference of two traces, so the
// wave-equation rows (20 states, through BLAS) move by 2.4e-10 (rough) and 7.0e-9 (smooth, err = 2e-8)
// between kernels, and their rates with them; those rows are pinned at 50 x their spread.
TEST(ReproduceAaltoTemporal, QuickValuesArePinned) {
  const std::vector<PinnedItem> pins = {
      {"scalar.trPc", 0.10049695688373365, kDirect, "new"},
      {"scalar.err.n=1", 0.0017951362598949833, kDirect, "new"},
      {"scalar.err.n=16", 7.0611774482531864e-06, kDirect, "new"},
      {"scalar.err.n=1024", 1.723972228862003e-09, kDirect, "new"},
      {"scalar.rate", -1.9999945538092938, kDirect, "new"},
      {"scalar.bound_over_err.n=1024", 11.581945112061558, kDirect, "new"},
      {"osc_B0.trPc", 0.37411641961768549, kDirect, "new"},
      {"osc_B0.err.n=1", 1.2602482854499035, kDirect, "new"},
      {"osc_B0.err.n=16", 0.0030355410345148104, kDirect, "new"},
      {"osc_B0.err.n=1024", 7.393345701212084e-07, kDirect, "new"},
      {"osc_B0.rate", -2.0004373742215424, kDirect, "new"},
      {"osc_B0.bound_over_err.n=1024", 8808.6164332253265, kDirect, "new"},
      {"osc_noise.trPc", 0.76724260141737555, kDirect, "new"},
      {"osc_noise.err.n=1", 1.5488799558887751, kDirect, "new"},
      {"osc_noise.err.n=16", 0.0041899212208050818, kDirect, "new"},
      {"osc_noise.err.n=1024", 1.0201085065553173e-06, kDirect, "new"},
      {"osc_noise.rate", -2.0005065462082703, kDirect, "new"},
      {"osc_noise.bound_over_err.n=1024", 42997.558501071995, kDirect, "new"},
      {"rw_highsnr.trPc", 0.0099999999999998146, kDirect, "new"},
      {"rw_highsnr.err.n=1", 0.30262655300852459, kDirect, "new"},
      {"rw_highsnr.err.n=16", 0.010628156324144451, kDirect, "new"},
      {"rw_highsnr.err.n=1024", 3.97285380684953e-06, kDirect, "new"},
      {"rw_highsnr.err.n=16384", 1.5522031255807422e-08, kDirect, "new"},
      {"rw_highsnr.rate", -1.9614354891978931, kDirect, "new"},
      {"rw_highsnr.bound_over_err.n=1024", 24590.647466569579, kDirect, "new"},
      {"wave.rough.rate", -1.3394318059411496, 2e-09, "new"},            // 50 x kernel spread 3.4e-11
      {"wave.rough.err.n=1024", 5.0621040683151985e-05, 2e-08, "new"},   // 50 x kernel spread 2.4e-10
      {"wave.smooth.rate", -2.0002887270476406, 5e-08, "new"},           // 50 x kernel spread 6.6e-10
      {"wave.smooth.err.n=1024", 1.9980618883377876e-08, 5e-07, "new"},  // 50 x kernel spread 7.0e-09
  };
  ExpectMatchesPins("aalto-temporal", pins);
}

}  // namespace
}  // namespace kfx
