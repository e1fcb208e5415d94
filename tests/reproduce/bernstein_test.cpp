// kfx reproduce bernstein: the item keys are a contract (docs/papers/001.md), and every quick value is pinned.
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

TEST(BernsteinReproduce, PrintsTheIssueKeysAndEveryRatioIsAtLeastOne) {
  const PaperReport& r = QuickReport("bernstein");
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

// Table: `kfx reproduce bernstein --quick --json` (OpenBLAS 0.3.21 Haswell kernel, AMD EPYC, 2026-12-02; the
// subspace rows since LeastDampedSubspace's basis is taken against a fixed frame, issue 20 class 15); to
// regenerate it after a deliberate change, follow tests/support/reproduce_pins.hpp. Tolerance kDirect
// (finite-horizon Riccati recursions and the exact-cost engine over 502 steps, no convergence test): with
// OPENBLAS_CORETYPE=Haswell, SkylakeX and Prescott every value agrees to 5.6e-13. (Sec. VI with n_e = 8 used to
// move by up to 6.1e-3 between kernels: its basis was picked by pivots that tie on the symmetric chain.)
TEST(BernsteinReproduce, QuickValuesArePinned) {
  const std::vector<PinnedItem> pins = {
      {"sec5.ne=8.reduced.onestep.k=10", 1.0428539419749203, kDirect, "new"},
      {"sec5.ne=8.reduced.onestep.k=100", 1.3956346020565336, kDirect, "new"},
      {"sec5.ne=8.reduced.onestep.k=500", 3.1362850317390354, kDirect, "new"},
      {"sec5.ne=8.reduced.twostep_da.k=10", 1.0255817812815782, kDirect, "new"},
      {"sec5.ne=8.reduced.twostep_da.k=100", 1.4206015823100393, kDirect, "new"},
      {"sec5.ne=8.reduced.twostep_da.k=500", 3.4950025933024085, kDirect, "new"},
      {"sec5.ne=8.reduced.twostep_f.k=10", 1.0360271363582714, kDirect, "new"},
      {"sec5.ne=8.reduced.twostep_f.k=100", 1.3670781707761077, kDirect, "new"},
      {"sec5.ne=8.reduced.twostep_f.k=500", 3.0703358274569226, kDirect, "new"},
      {"sec5.ne=8.subspace.onestep.k=10", 1.0982984298503193, kDirect, "new"},
      {"sec5.ne=8.subspace.onestep.k=100", 1.3175770256723622, kDirect, "new"},
      {"sec5.ne=8.subspace.onestep.k=500", 1.367388409151881, kDirect, "new"},
      {"sec5.ne=8.subspace.twostep_da.k=10", 1.098927167687642, kDirect, "new"},
      {"sec5.ne=8.subspace.twostep_da.k=100", 1.3230730575025442, kDirect, "new"},
      {"sec5.ne=8.subspace.twostep_da.k=500", 1.3754094996578836, kDirect, "new"},
      {"sec5.ne=16.reduced.onestep.k=10", 1.0585509263384494, kDirect, "new"},
      {"sec5.ne=16.reduced.onestep.k=100", 1.461894906623478, kDirect, "new"},
      {"sec5.ne=16.reduced.onestep.k=500", 1.748041776431539, kDirect, "new"},
      {"sec5.ne=16.reduced.twostep_da.k=10", 1.0551052370332055, kDirect, "new"},
      {"sec5.ne=16.reduced.twostep_da.k=100", 1.7947140677401832, kDirect, "new"},
      {"sec5.ne=16.reduced.twostep_da.k=500", 2.30870323832269, kDirect, "new"},
      {"sec5.ne=16.reduced.twostep_f.k=10", 1.0496681855153684, kDirect, "new"},
      {"sec5.ne=16.reduced.twostep_f.k=100", 1.4503726909776535, kDirect, "new"},
      {"sec5.ne=16.reduced.twostep_f.k=500", 1.7335645696201207, kDirect, "new"},
      {"sec5.ne=16.subspace.onestep.k=10", 1.099279658542947, kDirect, "new"},
      {"sec5.ne=16.subspace.onestep.k=100", 1.2375292854164093, kDirect, "new"},
      {"sec5.ne=16.subspace.onestep.k=500", 1.2351244341396053, kDirect, "new"},
      {"sec5.ne=16.subspace.twostep_da.k=10", 1.107851324052577, kDirect, "new"},
      {"sec5.ne=16.subspace.twostep_da.k=100", 1.2813156520456985, kDirect, "new"},
      {"sec5.ne=16.subspace.twostep_da.k=500", 1.2787550624061443, kDirect, "new"},
      {"sec6.ne=4.subspace.onestep.k=10", 1.0431331420931198, kDirect, "new"},
      {"sec6.ne=4.subspace.onestep.k=100", 1.2305906822796078, kDirect, "new"},
      {"sec6.ne=4.subspace.onestep.k=500", 1.7979106828823352, kDirect, "new"},
      {"sec6.ne=8.subspace.onestep.k=10", 1.0700759483841045, kDirect, "new"},
      {"sec6.ne=8.subspace.onestep.k=100", 1.0956274778560628, kDirect, "new"},
      {"sec6.ne=8.subspace.onestep.k=500", 1.1010389954718989, kDirect, "new"},
  };
  ExpectMatchesPins("bernstein", pins);
}

}  // namespace
}  // namespace kfx
