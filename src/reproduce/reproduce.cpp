#include "kfx/reproduce.hpp"

#include <cmath>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <sstream>

#include "kfx/error.hpp"
#include "reproduce/papers.hpp"

namespace kfx {

namespace {

using Reproducer = PaperReport (*)(const ReproduceOptions&);

struct PaperInfo {
  const char* id;
  const char* title;
  const char* reference;  // the paper's full reference (docs/papers/README.md)
  // The paper's reproduction, defined in its own src/reproduce_<paper>.cpp (declared in
  // src/reproduce/papers.hpp). Explicit, not self-registering: a static library drops objects
  // that nothing references.
  Reproducer reproduce;
};

const PaperInfo kPapers[] = {
    {"aalto-spatial", "Aalto: spatial discretization error in Kalman filtering (000)",
     "A. Aalto, \"Spatial discretization error in Kalman filtering for discrete-time infinite dimensional "
     "systems\", IMA Journal of Mathematical Control and Information (Oxford University Press); preprint "
     "arXiv:1406.7160",
     detail::ReproduceAaltoSpatial},
    {"bernstein", "Chandrasekar, Kim, Bernstein: finite-horizon reduced-order estimators (001)",
     "J. Chandrasekar, I. S. Kim, D. S. Bernstein (University of Michigan), finite-horizon optimal reduced-order "
     "estimators for discrete-time time-varying systems (title, venue and year unconfirmed)",
     detail::ReproduceBernstein},
    {"patel-toda", "Patel, Toda: modeling error analysis of stationary filters (002)",
     "R. Patel, M. Toda, \"Modeling error analysis of stationary linear discrete-time filters\", NASA Technical "
     "Memorandum TM X-73,225, NASA Ames Research Center, Moffett Field, California, February 1977",
     detail::ReproducePatelToda},
    {"aalto-temporal", "Aalto: convergence of discrete to continuous-time Kalman filter (003)",
     "A. Aalto, \"Convergence of discrete time Kalman filter estimate to continuous time estimate\", "
     "International Journal of Control (accepted for publication); preprint arXiv:1408.1275",
     detail::ReproduceAaltoTemporal},
    {"block-diagonal", "Pogorelyuk, Rowley, Kasdin: block-diagonal Kalman filter approximation (004)",
     "L. Pogorelyuk, C. W. Rowley, N. J. Kasdin, \"An efficient approximation of the Kalman filter for multiple "
     "systems coupled via low-dimensional stochastic input\", preprint arXiv:1911.10443",
     detail::ReproduceBlockDiagonal},
};

const PaperInfo* FindPaper(const std::string& id) {
  for (const auto& p : kPapers)
    if (id == p.id) return &p;
  return nullptr;
}

std::string IdList() {
  std::string s;
  for (const auto& p : kPapers) s += std::string(s.empty() ? "" : ", ") + p.id;
  return s + ", all";
}

std::string FormatNumber(std::optional<double> v) {
  if (!v) return "-";
  std::ostringstream os;
  os << std::setprecision(6) << *v;
  return os.str();
}

}  // namespace

std::optional<double> ReproduceItem::rel_diff() const {
  if (!published) return std::nullopt;
  const double denom = std::abs(*published) > 0 ? std::abs(*published) : 1.0;
  return std::abs(value - *published) / denom;
}

std::string ReproduceItem::status() const {
  const auto d = rel_diff();
  if (!d) return "new";
  return *d <= tolerance ? "reproduced" : "differs";
}

std::vector<std::string> PaperIds() {
  std::vector<std::string> ids;
  for (const auto& p : kPapers) ids.push_back(p.id);
  return ids;
}

PaperReport Reproduce(const std::string& paper, const ReproduceOptions& options) {
  const PaperInfo* info = FindPaper(paper);
  if (!info) throw Error("paper: expected one of " + IdList() + ", got '" + paper + "'");
  PaperReport report;
  if (info->reproduce) report = info->reproduce(options);
  report.paper = info->id;
  report.title = info->title;
  report.reference = info->reference;
  if (!info->reproduce) {
    report.notes.push_back("no reproduction items for this paper in this version of kfx (its issue is open)");
  }
  return report;
}

namespace {

// `text` in lines of at most `width` characters, broken at spaces (a word longer than `width` keeps its
// own line whole), never inside "NAME = VALUE": a description is never cut inside a number or apart
// from what the number is.
std::vector<std::string> WrapWords(const std::string& text, size_t width) {
  std::vector<std::string> units;
  std::istringstream words(text);
  for (std::string w; words >> w;) {
    if (w == "=" && !units.empty()) {
      units.back() += " =";
    } else if (!units.empty() && units.back().size() >= 2 &&
               units.back().compare(units.back().size() - 2, 2, " =") == 0) {
      units.back() += " " + w;
    } else {
      units.push_back(w);
    }
  }
  std::vector<std::string> lines;
  std::string line;
  for (const std::string& w : units) {
    if (!line.empty() && line.size() + 1 + w.size() > width) {
      lines.push_back(line);
      line.clear();
    }
    line += (line.empty() ? "" : " ") + w;
  }
  if (!line.empty() || lines.empty()) lines.push_back(line);
  return lines;
}

}  // namespace

std::string FormatReportTable(const PaperReport& r) {
  std::ostringstream os;
  os << "== " << r.paper << ": " << r.title << "\n";
  if (!r.items.empty()) {
    constexpr size_t kDescriptionWidth = 60;
    size_t wk = 3, wd = 11;
    for (const auto& it : r.items) {
      wk = std::max(wk, it.key.size());
      for (const auto& line : WrapWords(it.description, kDescriptionWidth)) wd = std::max(wd, line.size());
    }
    os << std::left << std::setw(static_cast<int>(wk)) << "key"
       << "  " << std::setw(static_cast<int>(wd)) << "description"
       << "  " << std::right << std::setw(13) << "published"
       << "  " << std::setw(13) << "kfx"
       << "  " << std::setw(9) << "rel.diff"
       << "  "
       << "status\n";
    for (const auto& it : r.items) {
      const auto d = it.rel_diff();
      std::ostringstream rd;
      if (d) rd << std::scientific << std::setprecision(1) << *d;
      const std::vector<std::string> lines = WrapWords(it.description, kDescriptionWidth);
      os << std::left << std::setw(static_cast<int>(wk)) << it.key << "  " << std::setw(static_cast<int>(wd))
         << lines.front() << "  " << std::right << std::setw(13) << FormatNumber(it.published) << "  " << std::setw(13)
         << FormatNumber(it.value) << "  " << std::setw(9) << (d ? rd.str() : "-") << "  " << it.status() << "\n";
      for (size_t i = 1; i < lines.size(); ++i) os << std::string(wk + 2, ' ') << lines[i] << "\n";
      if (!it.note.empty()) os << "    note: " << it.note << "\n";
    }
  }
  for (const auto& n : r.notes) os << "  " << n << "\n";
  for (const auto& f : r.figures) os << "  figure: " << f << "\n";
  return os.str();
}

std::string FormatReportSummary(const PaperReport& r, const std::string& full_table) {
  int reproduced = 0, differs = 0, fresh = 0;
  std::vector<const ReproduceItem*> key;  // every "differs" row, then reproduced rows, at most 4
  for (const auto& it : r.items) {
    const std::string st = it.status();
    reproduced += st == "reproduced";
    differs += st == "differs";
    fresh += st == "new";
    if (st == "differs" && key.size() < 4) key.push_back(&it);
  }
  for (const auto& it : r.items) {
    if (it.status() == "reproduced" && key.size() < 4) key.push_back(&it);
  }
  std::ostringstream os;
  os << "== " << r.paper << ": " << r.title << "\n   " << r.items.size() << " items: " << reproduced << " reproduced, "
     << differs << " differs, " << fresh << " new\n";
  for (const ReproduceItem* it : key) {
    const auto d = it->rel_diff();
    std::ostringstream rd;
    if (d) rd << std::scientific << std::setprecision(1) << *d;
    os << "   " << it->status() << ": " << it->key << " = " << FormatNumber(std::optional<double>(it->value))
       << " (published " << FormatNumber(it->published) << ", rel. diff " << (d ? rd.str() : "-")
       << "): " << it->description << "\n";
  }
  if (!r.figures.empty()) os << "   " << r.figures.size() << " figure files, e.g. " << r.figures.front() << "\n";
  if (!full_table.empty()) os << "   full table: " << full_table << "\n";
  return os.str();
}

std::string ReportsToJson(const std::vector<PaperReport>& reports, bool as_all) {
  auto one = [](const PaperReport& r) {
    nlohmann::ordered_json items = nlohmann::ordered_json::array();
    for (const auto& it : r.items) {
      nlohmann::ordered_json j;
      j["key"] = it.key;
      j["description"] = it.description;
      j["published"] = it.published ? nlohmann::ordered_json(*it.published) : nlohmann::ordered_json(nullptr);
      j["value"] = std::isfinite(it.value) ? nlohmann::ordered_json(it.value) : nlohmann::ordered_json(nullptr);
      const auto d = it.rel_diff();
      j["rel_diff"] = d && std::isfinite(*d) ? nlohmann::ordered_json(*d) : nlohmann::ordered_json(nullptr);
      j["status"] = it.status();
      items.push_back(j);
    }
    nlohmann::ordered_json j;
    j["paper"] = r.paper;
    j["items"] = items;
    j["figures"] = r.figures;
    return j;
  };
  if (!as_all) {
    if (reports.size() != 1) throw Error("reports: expected exactly one report without 'all'");
    return one(reports[0]).dump(2);
  }
  nlohmann::ordered_json papers = nlohmann::ordered_json::array();
  for (const auto& r : reports) papers.push_back(one(r));
  nlohmann::ordered_json j;
  j["papers"] = papers;
  return j.dump(2);
}

}  // namespace kfx
