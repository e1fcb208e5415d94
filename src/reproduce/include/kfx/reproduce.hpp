#pragma once
// `kfx reproduce`: each paper's published numbers beside kfx's own. The JSON layout written by
// ReportsToJson is a contract other tools read (issue "Foundation"):
//   {"paper": ID, "items": [{"key": K, "description": D, "published": number-or-null,
//    "value": number, "rel_diff": number-or-null, "status": "reproduced"|"differs"|"new"}],
//    "figures": [paths]}            -- and for `all`: {"papers": [ ... ]}
// Paper ids: aalto-spatial (000), bernstein (001), patel-toda (002), aalto-temporal (003),
// block-diagonal (004). Item keys are fixed by the paper issues.
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "kfx/progress.hpp"

namespace kfx {

struct ReproduceItem {
  std::string key;
  std::string description;
  std::optional<double> published;  ///< the paper's number, if it prints one
  double value = 0.0;               ///< kfx's number
  /// Relative tolerance under which |value - published| / |published| counts as reproduced.
  double tolerance = 0.0;
  /// Why a published number is not reproduced (unstated setting, typo in the paper, ...).
  std::string note;
  std::optional<double> rel_diff() const;
  /// "reproduced", "differs" or "new" (no published number).
  std::string status() const;
};

struct ReproduceOptions {
  bool quick = false;   ///< small, fast versions (tests, CI)
  std::string out_dir;  ///< where figures/data go (empty: none written)
  ProgressCallback progress;
};

struct PaperReport {
  std::string paper;  ///< one of PaperIds()
  std::string title;
  std::string reference;  ///< the paper's full reference (as in docs/papers/README.md)
  std::vector<ReproduceItem> items;
  std::vector<std::string> figures;  ///< paths written
  std::vector<std::string> notes;    ///< free text shown under the table
};

/// The ids accepted by Reproduce, in paper order.
std::vector<std::string> PaperIds();

/// Runs the reproduction of one paper. @throws kfx::Error for an unknown id (the message lists the ids).
PaperReport Reproduce(const std::string& paper, const ReproduceOptions& options = ReproduceOptions());

/// The table printed by the CLI (descriptions wrapped at spaces, never cut).
std::string FormatReportTable(const PaperReport& report);
/// A short summary of a report: counts of reproduced, differs and new items, up to four key rows
/// (every "differs" row first), the figures, and where the full table is (`full_table`, if not empty).
std::string FormatReportSummary(const PaperReport& report, const std::string& full_table);
/// JSON text of one report, or of several as {"papers": [...]} when `as_all` is true.
std::string ReportsToJson(const std::vector<PaperReport>& reports, bool as_all);

}  // namespace kfx
