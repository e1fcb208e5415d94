// `kfx reproduce`: each paper's published numbers beside kfx's (the kfx_reproduce library), the report
// tables on stdout, the items as JSON, and the figures drawn from the CSV data with kfx.plots.
#include <iostream>

#include "commands.hpp"
#include "figures.hpp"
#include "kfx/reproduce.hpp"
#include "output.hpp"
#include "progress.hpp"

namespace kfx::cli {

int RunReproduce(const ReproduceArgs& a) {
  std::vector<std::string> ids;
  const bool all = a.paper == "all";
  if (all) {
    ids = PaperIds();
  } else {
    ids.push_back(a.paper);
  }
  std::vector<PaperReport> reports;
  for (const auto& id : ids) {
    ReproduceOptions opt;
    opt.quick = a.quick;
    if (!a.out.empty()) {
      opt.out_dir = Join(a.out, id);
      MakeDir(opt.out_dir);
    }
    ProgressLine progress("reproduce " + id);
    opt.progress = progress.callback();
    reports.push_back(Reproduce(id, opt));
    progress.Finish();
    if (!a.brief) {
      std::cout << FormatReportTable(reports.back()) << std::flush;
    } else if (!a.out.empty()) {
      const std::string table = Join(opt.out_dir, "table.txt");
      WriteText(table, FormatReportTable(reports.back()));
      std::cout << FormatReportSummary(reports.back(), table) << std::flush;
    } else {
      std::cout << FormatReportSummary(reports.back(), "run without --brief") << std::flush;
    }
  }
  if (!a.json.empty()) WriteText(a.json, ReportsToJson(reports, all));
  if (!a.out.empty()) DrawFigures(a.out);
  return 0;
}

}  // namespace kfx::cli
