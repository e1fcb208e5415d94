// `kfx mismatch`: how robust a steady-state filter is to model errors: the worst and best case over
// element-wise error ranges (box search) and the Patel-Toda bounds (paper 002).
#include <cmath>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "commands.hpp"
#include "kfx/error.hpp"
#include "kfx/error_ranges_file.hpp"
#include "kfx/io.hpp"
#include "kfx/kalman_filter.hpp"
#include "kfx/mismatch.hpp"
#include "kfx/performance.hpp"
#include "kfx/riccati.hpp"
#include "output.hpp"

using Eigen::MatrixXd;

namespace kfx::cli {

namespace {

// "dA(1,2) = +0.1, dR(1,1) = -0.5" (1-based, nonzero entries; Delta = model - true).
std::string ErrorsString(const ModelingErrors& e) {
  std::ostringstream os;
  os << std::showpos << std::setprecision(6);
  const MatrixXd* mats[4] = {&e.A, &e.C, &e.Q, &e.R};
  const char* names[4] = {"dA", "dC", "dQ", "dR"};
  bool any = false;
  for (int w = 0; w < 4; ++w) {
    const MatrixXd& m = *mats[w];
    for (Eigen::Index i = 0; i < m.rows(); ++i)
      for (Eigen::Index j = 0; j < m.cols(); ++j) {
        if (m(i, j) == 0.0 || (w >= 2 && j < i)) continue;
        os << (any ? ", " : "") << names[w] << "(" << std::noshowpos << i + 1 << "," << j + 1 << std::showpos
           << ") = " << m(i, j);
        any = true;
      }
  }
  return any ? os.str() : "no error";
}

nlohmann::ordered_json ExtremeJson(const ErrorBoxExtreme& e) {
  nlohmann::ordered_json j;
  j["found"] = e.found;
  if (!e.found) return j;
  j["value"] = e.value;
  j["at_corner"] = e.at_corner;
  j["errors"] = {
      {"A", ToJson(e.errors.A)}, {"C", ToJson(e.errors.C)}, {"Q", ToJson(e.errors.Q)}, {"R", ToJson(e.errors.R)}};
  j["evaluations"] = e.evaluations;
  j["skipped"] = e.skipped;
  return j;
}

}  // namespace

int RunMismatch(const MismatchArgs& a) {
  const Model model = LoadModel(a.model);
  if (!model.time_invariant()) throw Error(a.model + ": expected a time-invariant model (002 is stationary)");
  if (model.input_dim() > 0) {
    throw Error(a.model +
                ": expected a model without a known input (G, D): kfx mismatch's stationary analysis has "
                "none (the library's StationaryMismatchedCovariance takes a constant one)");
  }
  const ModelStep design = *model.step(1);
  const ErrorRanges ranges = LoadErrorRanges(a.ranges, design);
  const PatelTodaBounds b = ComputePatelTodaBounds(design, ranges);
  b.summary.RequireOk();
  ErrorBoxSearchOptions so;
  so.refine = !a.no_refine;
  // The box search varies A, C, Q, R only: with the truth's S or an unmodelled input (issue 22) it is not run.
  const bool searchable = b.norms.S == 0.0 && !ranges.unmodelled_input;
  ErrorBoxSearch box;
  if (searchable) {
    box = SearchErrorBox(design, ranges, MismatchOptions(), so);
    box.summary.RequireOk();
  }
  const LinearFilter f = ConstantGainAsLinearFilter(design, b.terms.filter_gain, model.m0());
  const StationaryPerformance engine = ExactStationaryPerformance(model, f);
  const DareSolution dare = SteadyStateDare(design);  // the design's S included
  nlohmann::ordered_json j;
  j["model"] = a.model;
  j["ranges"] = a.ranges;
  std::cout << std::setprecision(6) << "filter designed on " << a.model
            << " (steady-state Kalman gain), n = " << model.state_dim() << ", m = " << model.meas_dim()
            << "\nerror ranges " << a.ranges << ": ";
  if (searchable) std::cout << "free entries " << box.free_entries << "; ";  // counted by the box search
  std::cout << "|dA| <= " << b.norms.A << ", |dC| <= " << b.norms.C << ", |dQ| <= " << b.norms.Q
            << ", |dR| <= " << b.norms.R;
  if (b.norms.S != 0.0) std::cout << ", |dS| <= " << b.norms.S;
  std::cout << " (Frobenius; Delta = model - true)\n"
            << "nominal (true system = model): true error tr P = " << b.terms.nominal_trace
            << " (the filter's own tr P_filt = " << dare.P_filt.trace() << ", engine " << engine.mse << ")\n";
  j["nominal_trace"] = b.terms.nominal_trace;
  auto extreme = [&](const char* what, const char* quantity, const ErrorBoxExtreme& e) {
    std::cout << what << ": " << quantity;
    if (!searchable) {
      std::cout << " not searched (the box search varies A, C, Q, R only; the ranges have S or an unmodelled input)\n";
      return;
    }
    if (!e.found) {
      std::cout << ": no valid true system in the box (" << e.evaluations
                << " evaluations, all skipped: Q or R not valid, the truth unstable (no stationary error) or a failed "
                   "solve)\n";
      return;
    }
    std::cout << " = " << e.value << " at " << ErrorsString(e.errors) << (e.at_corner ? " (corner)" : " (inside)")
              << "; " << e.evaluations << " evaluations, " << e.skipped << " skipped\n";
  };
  extreme("worst case over the box (corners, then refinement)", "max tr P", box.least_upper);
  extreme("best optimal filter over the box", "min tr P_F", box.greatest_lower);
  j["least_upper"] = ExtremeJson(box.least_upper);
  j["greatest_lower"] = ExtremeJson(box.greatest_lower);
  const double worst = box.least_upper.found ? box.least_upper.value : NAN;
  const double best = box.greatest_lower.found ? box.greatest_lower.value : NAN;
  std::cout << "guaranteed bounds (Patel, Toda 1977; ratio = how conservative against the box search):\n";
  nlohmann::ordered_json bounds;
  auto upper = [&](const char* name, const std::optional<double>& v, const char* what) {
    if (!v) return;
    std::cout << "  " << name << ": tr P   <= " << std::setw(10) << *v;
    if (std::isfinite(worst)) std::cout << "   ratio to max tr P  " << *v / worst;  // no box search: no ratio
    std::cout << "   " << what << "\n";
    bounds[name] = *v;
  };
  auto lower = [&](const char* name, const std::optional<double>& v, const char* what) {
    if (!v) return;
    std::cout << "  " << name << ": tr P_F >= " << std::setw(10) << *v;
    if (std::isfinite(best)) std::cout << "   ratio min tr P_F to it " << best / *v;
    std::cout << "   " << what << "\n";
    bounds[name] = *v;
  };
  upper("pi3", b.pi3, "(Theorem 3, noise covariance errors)");
  lower("pi4", b.pi4, "(Theorem 4, noise covariance errors)");
  upper("pi5", b.pi5, "(Theorem 5, plant errors; Lemma with the sound beta)");
  if (b.pi5_printed) {
    upper("pi5_printed", b.pi5_printed,
          b.lemma->printed_is_valid ? "(Theorem 5 with (41) as printed; valid here)"
                                    : "(Theorem 5 with (41) as printed: NOT guaranteed, x > 0.797)");
  }
  lower("pi6", b.pi6, "(Theorem 6, plant errors)");
  for (const std::string& why : b.refused) std::cout << "  refused " << why << "\n";
  j["refused"] = b.refused;
  if (!b.pi3 && !b.pi5 && b.refused.empty()) {
    std::cout << "  none: the ranges include both plant (A, C) and noise (Q, R) errors; Theorems 3-4 need exact "
                 "A, C and Theorems 5-6 exact Q, R\n";
  }
  if (b.lemma) {
    std::cout << "  Lemma: |U|_s <= " << b.lemma->beta << " (x = " << b.lemma->x << ", kappa = " << b.lemma->kappa
              << ", sigma = " << b.lemma->sigma << ")" << (b.lemma->applies() ? "" : ": " + b.lemma->summary.message)
              << "\n";
    bounds["lemma"] = {{"beta", b.lemma->beta},
                       {"beta_printed", b.lemma->beta_printed},
                       {"x", b.lemma->x},
                       {"kappa", b.lemma->kappa},
                       {"sigma", b.lemma->sigma}};
  }
  j["bounds"] = bounds;
  if (!a.json.empty()) WriteText(a.json, j.dump(2));
  return 0;
}

}  // namespace kfx::cli
