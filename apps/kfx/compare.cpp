// `kfx compare MODEL --method SPEC ...`: one row per method (kfx::Compare): its state dimension, offline
// time, online time per step, memory, exact (weighted) MSE at T and stationary, ratio to the optimal
// Kalman filter, its claimed error, Monte Carlo; JSON, and with --out the curves and figures.
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "commands.hpp"
#include "figures.hpp"
#include "kfx/compare.hpp"
#include "kfx/error.hpp"
#include "kfx/io.hpp"
#include "kfx/summary.hpp"
#include "output.hpp"
#include "progress.hpp"

namespace kfx::cli {

namespace {

nlohmann::ordered_json Number(double v) {
  return std::isfinite(v) ? nlohmann::ordered_json(v) : nlohmann::ordered_json();
}

std::string Cell(double v, int precision = 4) { return std::isfinite(v) ? FormatNumber(v, precision) : "-"; }

std::string Bytes(double b) {
  const char* units[] = {"B", "kB", "MB", "GB"};
  int u = 0;
  while (b >= 1000 && u < 3) {
    b /= 1000;
    ++u;
  }
  std::ostringstream os;
  os.precision(3);
  os << b << " " << units[u];
  return os.str();
}

nlohmann::ordered_json FieldsJson(const std::vector<CompareField>& fields) {
  nlohmann::ordered_json o;
  for (const CompareField& f : fields) {
    switch (f.kind) {
      case CompareField::Kind::kText:
        o[f.name] = f.null_if_empty && f.text.empty() ? nlohmann::ordered_json() : nlohmann::ordered_json(f.text);
        break;
      case CompareField::Kind::kInteger:
        o[f.name] = static_cast<long long>(f.number);
        break;
      case CompareField::Kind::kFlag:
        o[f.name] = f.number != 0;
        break;
      case CompareField::Kind::kNumber:
        o[f.name] = Number(f.number);
        break;
    }
  }
  return o;
}

nlohmann::ordered_json CompareJson(const Comparison& c, const std::string& model) {
  nlohmann::ordered_json j;
  j["model"] = model;
  j.update(FieldsJson(ComparisonFields(c)));
  nlohmann::ordered_json rows = nlohmann::ordered_json::array();
  for (const CompareRow& r : c.rows) rows.push_back(FieldsJson(CompareRowFields(r, c.stationary)));
  j["rows"] = rows;
  return j;
}

void PrintTable(const Comparison& c) {
  const bool mc = !c.rows.empty() && c.rows.front().mc_runs > 0;
  std::printf("optimal Kalman filter on the true model: MSE at T = %d: %s, stationary (DARE): %s\n", c.steps,
              Cell(c.kalman_final, 6).c_str(), Cell(c.kalman_stationary, 6).c_str());
  if (std::isfinite(c.kalman_bucy_final)) {
    std::printf("Kalman-Bucy filter (observes y continuously; a lower bound): MSE at T: %s, stationary (CARE): %s\n",
                Cell(c.kalman_bucy_final, 6).c_str(), Cell(c.kalman_bucy_stationary, 6).c_str());
  }
  std::printf("%-34s %5s %9s %11s %9s %11s %11s %7s %11s %11s", "method", "n_z", "offline", "online/step", "memory",
              "MSE(T)", "stationary", "ratio", "claimed", "claimed st.");
  if (mc) std::printf(" %22s", "Monte Carlo MSE(T)");
  std::printf("\n");
  for (const CompareRow& r : c.rows) {
    const std::string spec = r.spec.size() > 34 ? r.spec.substr(0, 31) + "..." : r.spec;
    std::printf("%-34s %5ld %8ss %10sus %9s %11s %11s %7s %11s %11s", spec.c_str(), static_cast<long>(r.state_dim),
                Cell(r.offline_seconds, 2).c_str(), Cell(1e6 * r.online_seconds_per_step, 3).c_str(),
                Bytes(r.memory_bytes).c_str(), Cell(r.final_mse).c_str(), Cell(r.stationary_mse).c_str(),
                Cell(r.ratio, 4).c_str(), Cell(r.claimed_final).c_str(), Cell(r.claimed_stationary).c_str());
    if (mc) std::printf(" %11s +- %-8s", Cell(r.mc_mse).c_str(), Cell(r.mc_std_error, 2).c_str());
    std::printf("\n");
  }
  std::printf("ratio: %s over the optimal Kalman filter's; claimed: the filter's own covariance; '-': none\n",
              c.stationary ? "stationary MSE" : "MSE(T)");
}

// compare_rows.csv (one row per method) and compare_curves.csv (k, then the MSE of each method): what
// kfx.plots draws the Pareto figure and the error-vs-time curves from.
void WriteCurves(const Comparison& c, const OutputDirectory& dir) {
  std::ostringstream rows;
  rows.precision(12);
  rows << "method,state_dim,online_seconds_per_step,memory_bytes,mse,stationary_mse,ratio,headline\n";
  for (const CompareRow& r : c.rows) {
    const double headline = c.stationary ? r.stationary_mse : r.final_mse;
    rows << '"' << r.spec << "\"," << r.state_dim << ',' << r.online_seconds_per_step << ',' << r.memory_bytes << ','
         << r.final_mse << ',' << r.stationary_mse << ',' << r.ratio << ',' << headline << '\n';
  }
  rows << "\"Kalman filter (reference)\",,,," << c.kalman_final << ',' << c.kalman_stationary << ",1,"
       << (c.stationary ? c.kalman_stationary : c.kalman_final) << '\n';
  std::string text = rows.str();
  text.pop_back();  // WriteText ends the file with one newline
  WriteText(dir.Path("compare_rows.csv"), text);
  std::ostringstream curves;
  curves.precision(12);
  curves << "k";
  for (const CompareRow& r : c.rows) curves << ",\"" << r.spec << '"';
  curves << '\n';
  for (int k = 0; k <= c.steps; ++k) {
    curves << k;
    for (const CompareRow& r : c.rows) curves << ',' << r.mse(k);
    curves << '\n';
  }
  text = curves.str();
  text.pop_back();
  WriteText(dir.Path("compare_curves.csv"), text);
}

}  // namespace

int RunCompare(const CompareArgs& a) {
  std::vector<MethodSpec> specs;
  for (const std::string& text : a.methods) specs.push_back(ParseMethodSpec(text));  // all checked before work
  const ComparisonModel truth = LoadComparisonModel(a.model);
  CompareOptions o;
  o.steps = a.steps;
  o.stationary = a.stationary;
  o.monte_carlo = a.monte_carlo;
  o.seed = a.seed;
  if (!a.weight.empty()) {
    try {
      o.weight = ReadNpyMatrix(a.weight);
    } catch (const Error& e) {
      throw Error(std::string("--weight: ") + e.what());
    }
  }
  ProgressLine progress("compare");
  o.progress = progress.callback();
  const Comparison c = Compare(truth, specs, o);
  progress.Finish();
  PrintTable(c);
  const std::string json = CompareJson(c, a.model).dump(2);
  if (!a.json.empty()) WriteText(a.json, json);
  if (!a.out.empty()) {
    // compare.json is the completion marker, written last (docs/robustness.md, class 5).
    OutputDirectory out(a.out, "compare.json");
    WriteCurves(c, out);
    DrawFigures(a.out);
    out.Commit(json);
    std::cout << "wrote compare.json, compare_rows.csv, compare_curves.csv to " << a.out << "\n";
  }
  return 0;
}

}  // namespace kfx::cli
