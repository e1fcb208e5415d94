// The reproduce registry and its JSON contract.
#include "kfx/reproduce.hpp"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "kfx/error.hpp"
#include "support/expect_error.hpp"

namespace kfx {
namespace {

TEST(Reproduce, PaperIdsAreTheContract) {
  EXPECT_EQ(PaperIds(),
            (std::vector<std::string>{"aalto-spatial", "bernstein", "patel-toda", "aalto-temporal", "block-diagonal"}));
  // Reproduce(id).paper == id for each id: in the paper's own test (ExpectMatchesPins), which computes the quick
  // reproduction anyway.
  // 'all' is the CLI's loop, not a paper
  EXPECT_TRUE(testing::ThrowsErrorNaming([] { Reproduce("all"); }, "paper"));
}

TEST(Reproduce, ItemStatusFromTolerance) {
  ReproduceItem it{"k", "d", 2.0, 2.01, 1e-2, ""};
  EXPECT_NEAR(*it.rel_diff(), 0.005, 1e-15);
  EXPECT_EQ(it.status(), "reproduced");
  it.tolerance = 1e-3;
  EXPECT_EQ(it.status(), "differs");
  it.published.reset();
  EXPECT_FALSE(it.rel_diff().has_value());
  EXPECT_EQ(it.status(), "new");
}

TEST(Reproduce, JsonLayout) {
  PaperReport r;
  r.paper = "patel-toda";
  r.items.push_back(ReproduceItem{"pi1", "bound", 1.5, 1.5, 1e-3, ""});
  r.items.push_back(ReproduceItem{"extra", "new number", std::nullopt, 3.0, 0.0, ""});
  r.figures.push_back("fig.png");
  const auto one = nlohmann::json::parse(ReportsToJson({r}, false));
  EXPECT_EQ(one["paper"], "patel-toda");
  EXPECT_EQ(one["items"][0]["status"], "reproduced");
  EXPECT_EQ(one["items"][0]["rel_diff"], 0.0);
  EXPECT_TRUE(one["items"][1]["published"].is_null());
  EXPECT_TRUE(one["items"][1]["rel_diff"].is_null());
  EXPECT_EQ(one["items"][1]["status"], "new");
  EXPECT_EQ(one["figures"][0], "fig.png");
  const auto all = nlohmann::json::parse(ReportsToJson({r, r}, true));
  EXPECT_EQ(all["papers"].size(), 2u);
  EXPECT_THROW(ReportsToJson({r, r}, false), Error);
  EXPECT_NE(FormatReportTable(r).find("reproduced"), std::string::npos);
}

// A long description is wrapped at spaces, never cut inside a number; the summary counts the statuses.
TEST(Reproduce, TableWrapsAndSummaryCounts) {
  PaperReport r;
  r.paper = "bernstein";
  const std::string desc =
      "one-step reduced-order filter, n_e = 2: J_k / J_k^KF at k = 100 (the cost ratio of the paper's figure)";
  r.items.push_back(ReproduceItem{"fig2.k100", desc, 1.5, 1.5, 1e-3, ""});
  r.items.push_back(ReproduceItem{"other", "a number", 2.0, 3.0, 1e-3, ""});
  r.items.push_back(ReproduceItem{"extra", "new number", std::nullopt, 3.0, 0.0, ""});
  const std::string table = FormatReportTable(r);
  EXPECT_NE(table.find("k = 100"), std::string::npos) << table;
  EXPECT_NE(table.find("figure)"), std::string::npos) << table;
  const std::string summary = FormatReportSummary(r, "out/table.txt");
  EXPECT_NE(summary.find("3 items: 1 reproduced, 1 differs, 1 new"), std::string::npos) << summary;
  EXPECT_NE(summary.find("differs: other = 3"), std::string::npos) << summary;
  EXPECT_NE(summary.find("full table: out/table.txt"), std::string::npos) << summary;
  EXPECT_LT(summary.find("differs: other"), summary.find("reproduced: fig2.k100")) << summary;
}

}  // namespace
}  // namespace kfx
