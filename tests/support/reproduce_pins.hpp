#pragma once
// Pinned results of `kfx reproduce PAPER --quick` (tests/reproduce/<paper>_test.cpp). Each paper's test holds a
// table {key, pinned value, relative tolerance, expected status} of kfx's own values when the table was made;
// ExpectMatchesPins fails when an item is added, removed or reordered, when a value drifts beyond its tolerance,
// or when an item changes status (reproduced / differs / new against the paper's number).
//
// How the tables were made (and how to regenerate one after a deliberate change of a reproduction):
//   OPENBLAS_NUM_THREADS=1 build/bin/kfx reproduce PAPER --quick --json /tmp/PAPER.json
//   python3 -c 'import json,sys; [print("{\"%s\", %s, TOL, \"%s\"}," % (i["key"], "kInfinity" if i["value"]
//     is None else "%.17g" % i["value"], i["status"])) for i in json.load(open(sys.argv[1]))["items"]]' /tmp/PAPER.json
// (the JSON writes a non-finite value as null: the tables pin +inf, what the reproductions give) and replace
// the rows of the table, keeping each row's tolerance (TOL) and the timing rows (kTimingItem); say in the
// commit which values moved and why.
// Tolerances: the class floor of the computation (kDirect, kIterative, kMonteCarlo below), raised for an item
// that moves more between BLAS kernels to 50 x the largest relative spread of its value over one run per
// OpenBLAS kernel (OPENBLAS_CORETYPE=Haswell, SkylakeX, Sandybridge, Prescott, Nehalem, Zen on one machine),
// rounded up to 1, 2 or 5 x 10^k; such rows say so in a comment. Re-measure the spread when a computation
// changes kind.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "kfx/reproduce.hpp"

namespace kfx::testing {

/// Relative tolerance of a direct computation (closed forms, finite recursions, direct factorizations): rounding
/// differences between BLAS kernels of ~1e-13 and their amplification leave a wide margin, and a drift of 1e-9
/// is already a change of the computation.
inline constexpr double kDirect = 1e-9;
/// Relative tolerance of an iterative computation (DARE doubling, Algorithm 2.3 schedules, steady states and box
/// searches, converged to 1e-10..1e-13 relative change): another kernel may stop one iteration earlier or
/// later, which moves a fixed point with contraction rho by up to tol / (1 - rho).
inline constexpr double kIterative = 1e-8;
/// Relative tolerance of a seeded Monte Carlo average: deterministic for one seed, but each sample passes
/// through BLAS (products, factorizations), so rounding differences of ~1e-12 are amplified by the filter's
/// nonlinearity (EKF relinearization) over the run; 1e-7 still catches a 1e-6 change.
inline constexpr double kMonteCarlo = 1e-7;
/// `tolerance` of an item whose value is a wall-clock time or a ratio of times: it varies from run to run, so
/// only that it is finite and positive is checked, neither its value nor its status.
inline constexpr double kTimingItem = -1.0;
/// The pinned value of an item that is +inf (e.g. a bound whose denominator is not positive).
inline constexpr double kInfinity = std::numeric_limits<double>::infinity();

struct PinnedItem {
  std::string key;
  double value;        ///< kfx's value when the table was made (17 significant digits), or kInfinity
  double tolerance;    ///< relative: |value - pinned| <= tolerance * |pinned|; or kTimingItem
  std::string status;  ///< "reproduced", "differs" or "new"
};

/// The quick reproduction of `paper`, computed once per test executable and shared by its tests.
inline const PaperReport& QuickReport(const std::string& paper) {
  static std::map<std::string, PaperReport> reports;
  auto found = reports.find(paper);
  if (found == reports.end()) found = reports.emplace(paper, Reproduce(paper, ReproduceOptions{true, "", {}})).first;
  return found->second;
}

/// Checks the quick reproduction of `paper` against `pins`: the report names the paper, has the same keys in
/// the same order, each value within its relative tolerance of the pinned one and each status the pinned one
/// (timing items: finite and positive only).
inline void ExpectMatchesPins(const std::string& paper, const std::vector<PinnedItem>& pins) {
  const PaperReport& report = QuickReport(paper);
  EXPECT_EQ(report.paper, paper);
  std::vector<std::string> keys, pinned_keys;
  for (const ReproduceItem& item : report.items) keys.push_back(item.key);
  for (const PinnedItem& pin : pins) pinned_keys.push_back(pin.key);
  ASSERT_EQ(keys, pinned_keys) << report.paper << ": the item keys or their order changed";
  for (std::size_t i = 0; i < pins.size(); ++i) {
    const PinnedItem& pin = pins[i];
    const ReproduceItem& item = report.items[i];
    if (pin.tolerance == kTimingItem) {
      EXPECT_TRUE(std::isfinite(item.value) && item.value > 0.0) << pin.key << " = " << item.value;
      continue;
    }
    if (std::isinf(pin.value)) {
      EXPECT_EQ(item.value, pin.value) << pin.key;
    } else {
      const double diff = std::abs(item.value - pin.value);
      std::ostringstream os;
      os.precision(17);
      os << pin.key << " = " << item.value << ", pinned " << pin.value << ": relative difference "
         << diff / std::abs(pin.value) << " > tolerance " << pin.tolerance;
      EXPECT_LE(diff, pin.tolerance * std::abs(pin.value)) << os.str();
    }
    EXPECT_EQ(item.status(), pin.status) << pin.key << " = " << item.value;
  }
}

}  // namespace kfx::testing
