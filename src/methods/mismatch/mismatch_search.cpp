// The search of an error box (paper 002, Sec. 6, the numbers in parentheses): the largest true error of the
// design's filter and the smallest optimal error over the true systems design - Delta, |Delta_ij| <= range_ij.
// API: include/kfx/mismatch.hpp.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "kfx/error.hpp"
#include "kfx/kalman_filter.hpp"
#include "kfx/mismatch.hpp"
#include "kfx/riccati.hpp"
#include "methods/mismatch/mismatch_internal.hpp"

namespace kfx {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;

// ---- error box search --------------------------------------------------------------------------

bool ErrorBoxSearchOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  if (max_corner_dimensions < 0 || max_corner_dimensions > 24)
    return fail("max_corner_dimensions: expected 0..24, got " + std::to_string(max_corner_dimensions));
  if (random_corners < 1) return fail("random_corners: expected >= 1, got " + std::to_string(random_corners));
  if (!(step_tolerance > 0.0 && step_tolerance < 1.0))
    return fail("step_tolerance: expected in (0, 1), got " + std::to_string(step_tolerance));
  if (max_evaluations < 1) return fail("max_evaluations: expected >= 1, got " + std::to_string(max_evaluations));
  return true;
}

namespace {

struct FreeEntry {
  int which;  // 0 A, 1 C, 2 Q, 3 R
  Index i, j;
  double range;
};

std::vector<FreeEntry> FreeEntries(const ErrorRanges& r) {
  std::vector<FreeEntry> out;
  const MatrixXd* mats[4] = {&r.A, &r.C, &r.Q, &r.R};
  for (int w = 0; w < 4; ++w) {
    const MatrixXd& m = *mats[w];
    for (Index j = 0; j < m.cols(); ++j)
      for (Index i = 0; i < m.rows(); ++i) {
        if (w >= 2 && i > j) continue;  // symmetric: (i, j) and (j, i) move together
        if (m(i, j) > 0.0) out.push_back({w, i, j, m(i, j)});
      }
  }
  return out;
}

ModelingErrors ErrorsAt(const ModelStep& design, const std::vector<FreeEntry>& free, const VectorXd& theta) {
  MatrixXd G, noise_cov;
  detail::NoiseInputOf(design, &G, &noise_cov);
  const Index n = design.A.rows(), m = design.C.rows(), p = noise_cov.rows();
  ModelingErrors e;
  e.A = MatrixXd::Zero(n, n);
  e.C = MatrixXd::Zero(m, n);
  e.Q = MatrixXd::Zero(p, p);
  e.R = MatrixXd::Zero(m, m);
  MatrixXd* mats[4] = {&e.A, &e.C, &e.Q, &e.R};
  for (size_t k = 0; k < free.size(); ++k) {
    const FreeEntry& f = free[k];
    (*mats[f.which])(f.i, f.j) = theta(static_cast<Index>(k));
    if (f.which >= 2) (*mats[f.which])(f.j, f.i) = theta(static_cast<Index>(k));
  }
  return e;
}

using Objective = std::function<bool(const ModelingErrors&, double*, ModelStep*)>;

// Maximizes sign * value over the box: corners, then a compass search from the best corner and
// from the centre.
ErrorBoxExtreme SearchExtreme(const ModelStep& design, const std::vector<FreeEntry>& free, const Objective& f,
                              double sign, const ErrorBoxSearchOptions& opt) {
  ErrorBoxExtreme best;
  const Index d = static_cast<Index>(free.size());
  VectorXd range(d);
  for (Index k = 0; k < d; ++k) range(k) = free[static_cast<size_t>(k)].range;
  VectorXd best_theta = VectorXd::Zero(d);
  auto eval = [&](const VectorXd& theta, double* value) {
    if (best.evaluations >= opt.max_evaluations) return false;
    ++best.evaluations;
    ModelStep truth;
    const ModelingErrors e = ErrorsAt(design, free, theta);
    if (!f(e, value, &truth)) {
      ++best.skipped;
      return false;
    }
    if (!best.found || sign * *value > sign * best.value) {
      best.found = true;
      best.value = *value;
      best.errors = e;
      best.truth = truth;
      best_theta = theta;
    }
    return true;
  };
  // Corners.
  double v = 0.0;
  if (d == 0) {
    eval(VectorXd::Zero(0), &v);
  } else if (d <= opt.max_corner_dimensions) {
    const long count = 1L << d;
    for (long c = 0; c < count && best.evaluations < opt.max_evaluations; ++c) {
      VectorXd theta(d);
      for (Index k = 0; k < d; ++k) theta(k) = ((c >> k) & 1) ? range(k) : -range(k);
      ++best.corners;
      eval(theta, &v);
    }
  } else {
    std::mt19937_64 gen(1);
    for (int c = 0; c < opt.random_corners && best.evaluations < opt.max_evaluations; ++c) {
      VectorXd theta(d);
      for (Index k = 0; k < d; ++k) theta(k) = (gen() & 1) ? range(k) : -range(k);
      ++best.corners;
      eval(theta, &v);
    }
  }
  const double corner_value = best.value;
  const bool corner_found = best.found;
  if (opt.refine && d > 0) {
    std::vector<VectorXd> starts;
    if (best.found) starts.push_back(best_theta);
    starts.push_back(VectorXd::Zero(d));
    for (const VectorXd& start : starts) {
      VectorXd theta = start;
      double cur = 0.0;
      if (!eval(theta, &cur)) continue;
      VectorXd step = 0.5 * range;
      while (best.evaluations < opt.max_evaluations && (step.array() / range.array()).maxCoeff() > opt.step_tolerance) {
        bool improved = false;
        for (Index k = 0; k < d && !improved; ++k) {
          for (double s : {1.0, -1.0}) {
            VectorXd trial = theta;
            trial(k) = std::clamp(theta(k) + s * step(k), -range(k), range(k));
            if (trial(k) == theta(k)) continue;
            double val = 0.0;
            if (eval(trial, &val) && sign * val > sign * cur + 1e-15 * std::abs(cur)) {
              theta = trial;
              cur = val;
              improved = true;
              break;
            }
          }
        }
        if (!improved) step *= 0.5;
      }
    }
  }
  if (best.found) {
    best.at_corner = true;
    for (Index k = 0; k < d; ++k) best.at_corner = best.at_corner && std::abs(best_theta(k)) == range(k);
    best.refinement_gain = corner_found ? sign * (best.value - corner_value) : 0.0;
  }
  return best;
}

}  // namespace

ErrorBoxSearch SearchErrorBox(const ModelStep& design, const ErrorRanges& ranges, const MismatchOptions& options,
                              const ErrorBoxSearchOptions& search) {
  std::string why;
  if (!search.IsValid(&why)) throw Error("search." + why);
  if (!options.IsValid(&why)) throw Error("options." + why);
  ValidateErrorRanges(design, ranges);
  if (ranges.S.size() > 0 && ranges.S.cwiseAbs().maxCoeff() > 0.0) {
    throw Error("ranges.S: expected no cross-covariance range (the error-box search varies A, C, Q, R only)");
  }
  if (ranges.unmodelled_input) {
    throw Error(
        "ranges.unmodelled_input: expected false (the error-box search has no known input; the true error "
        "with an input is StationaryMismatchedCovariance's)");
  }
  const auto start = std::chrono::steady_clock::now();
  MismatchOptions fixed = options;
  ErrorBoxSearch out;
  out.summary.method = "corners, then compass search";
  if (!detail::ResolveFilterGain(design, options, &fixed.filter_gain, &out.summary)) {
    detail::FinishSummary("error-box search", start, &out.summary);
    return out;
  }
  const std::vector<FreeEntry> free = FreeEntries(ranges);
  out.free_entries = static_cast<int>(free.size());
  const Objective true_error = [&](const ModelingErrors& e, double* value, ModelStep* truth) {
    try {
      *truth = ApplyModelingErrors(design, e);
    } catch (const Error&) {
      return false;
    }
    const StationaryMismatch s = StationaryMismatchedCovariance(design, *truth, fixed);
    if (!s.summary.ok() || !std::isfinite(s.trace)) return false;
    *value = s.trace;
    return true;
  };
  const Objective optimal_error = [&](const ModelingErrors& e, double* value, ModelStep* truth) {
    try {
      *truth = ApplyModelingErrors(design, e);
    } catch (const Error&) {
      return false;
    }
    DareSolution dare;
    try {
      dare = SteadyStateDare(*truth);  // the truth's optimal filter, its S (the design's) included
    } catch (const Error&) {           // C Q C^T + C S + S^T C^T + R not positive definite: not a valid truth
      return false;
    }
    if (!dare.summary.ok()) return false;
    *value = dare.P_filt.trace();
    return std::isfinite(*value);
  };
  out.least_upper = SearchExtreme(design, free, true_error, 1.0, search);
  out.greatest_lower = SearchExtreme(design, free, optimal_error, -1.0, search);
  out.summary.termination = Termination::kConverged;
  out.summary.iterations = out.least_upper.evaluations + out.greatest_lower.evaluations;
  detail::FinishSummary("error-box search", start, &out.summary);
  return out;
}

}  // namespace kfx
