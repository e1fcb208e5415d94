// `kfx reproduce patel-toda`: the twelve numbers of Sec. 6 of paper 002 (Patel, Toda 1977) — the
// bounds of Theorems 3-6 and, in parentheses in the paper, the least upper bound of tr P and the
// greatest lower bound of tr P_F over the error box. Corrections and readings: docs/papers/002.md.
// Paper 002: R. Patel, M. Toda, "Modeling error analysis of stationary linear discrete-time filters",
// NASA TM X-73,225, NASA Ames Research Center, February 1977 (docs/papers/README.md).
#include <cmath>
#include <sstream>

#include "kfx/mismatch.hpp"
#include "reproduce/papers.hpp"

namespace kfx::detail {

namespace {

using Eigen::MatrixXd;

// Sec. 6: a_M1 = -1/3, a_M2 = 1/10, a_M3 = -1/4, G = [1, 0]^T, H = [1, 0], q_M = 10, r_M = 5.
ModelStep PatelTodaDesign() {
  MatrixXd A(2, 2), G(2, 1), H(1, 2);
  A << -1.0 / 3.0, 0.0, 0.1, -0.25;
  G << 1.0, 0.0;
  H << 1.0, 0.0;
  return MakeStepWithNoiseInput(A, G, MatrixXd::Constant(1, 1, 10.0), H, MatrixXd::Constant(1, 1, 5.0));
}

// The paper prints four significant digits: agreement to half a unit of the last digit.
ReproduceItem FourDigitItem(const std::string& key, const std::string& description, double published, double value) {
  return Item(key, description, published, value, 0.5e-3 / std::abs(published) + 1e-12);
}

std::string Num(double v, int precision = 5) {
  std::ostringstream os;
  os.precision(precision);
  os << v;
  return os.str();
}

}  // namespace

PaperReport ReproducePatelToda(const ReproduceOptions& options) {
  PaperReport report;
  const ModelStep design = PatelTodaDesign();
  const DesignTerms terms = ComputeDesignTerms(design);
  terms.summary.RequireOk();
  ErrorRanges case1, case2, plant;
  case1.Q = MatrixXd::Constant(1, 1, 1.0);  // |dq| <= 1, dr = 0
  case2.R = MatrixXd::Constant(1, 1, 0.5);  // |dr| <= 0.5, dq = 0
  plant.A = MatrixXd::Zero(2, 2);
  plant.A(0, 0) = 0.1;  // |da_M1| <= 0.1
  const ErrorNorms n1 = ErrorNormsFromRanges(case1), n2 = ErrorNormsFromRanges(case2), np = ErrorNormsFromRanges(plant);
  if (options.progress) options.progress(0, 3);
  const ErrorBoxSearch s1 = SearchErrorBox(design, case1);
  const ErrorBoxSearch s2 = SearchErrorBox(design, case2);
  if (options.progress) options.progress(2, 3);
  const ErrorBoxSearch sp = SearchErrorBox(design, plant);
  for (const ErrorBoxSearch* s : {&s1, &s2, &sp}) s->summary.RequireOk();
  if (options.progress) options.progress(3, 3);

  const double pi4_1 = Theorem4Bound(design, n1), pi4_2 = Theorem4Bound(design, n2);
  const double pi4_1t = Theorem4Bound(design, n1, EigenvalueTerm::kTraceSquared);
  const double pi4_2t = Theorem4Bound(design, n2, EigenvalueTerm::kTraceSquared);
  const Theorem5Result t5 = Theorem5Bound(design, terms, np);

  report.items.push_back(
      FourDigitItem("thm3.case1.pi3", "Thm 3 upper bound on tr P, |dq| <= 1", 3.567, Theorem3Bound(terms, n1)));
  report.items.push_back(
      FourDigitItem("thm3.case1.least_upper", "max tr P over |dq| <= 1 (box search)", 3.519, s1.least_upper.value));
  report.items.push_back(
      FourDigitItem("thm3.case2.pi3", "Thm 3 upper bound on tr P, |dr| <= 0.5", 3.748, Theorem3Bound(terms, n2)));
  report.items.push_back(
      FourDigitItem("thm3.case2.least_upper", "max tr P over |dr| <= 0.5 (box search)", 3.644, s2.least_upper.value));
  ReproduceItem it = FourDigitItem("thm4.case1.pi4", "Thm 4 lower bound on tr P_F, |dq| <= 1", 2.206, pi4_1);
  it.note = "(34)-(37) as printed (l = 1 in (37)) give " + Num(pi4_1) + "; with (1/n)[tr A]^2 in place of " +
            "sum |lambda_i(A)|^2 in (36) (Lemma 2, as in Thm 6) they give " + Num(pi4_1t) + ", the published digits";
  report.items.push_back(it);
  report.items.push_back(FourDigitItem("thm4.case1.greatest_lower", "min tr P_F over |dq| <= 1 (box search)", 3.295,
                                       s1.greatest_lower.value));
  it = FourDigitItem("thm4.case2.pi4", "Thm 4 lower bound on tr P_F, |dr| <= 0.5", 2.432, pi4_2);
  it.note = "as printed " + Num(pi4_2) + "; with (1/n)[tr A]^2 for sum |lambda_i(A)|^2: " + Num(pi4_2t) +
            ", the published digits";
  report.items.push_back(it);
  report.items.push_back(FourDigitItem("thm4.case2.greatest_lower", "min tr P_F over |dr| <= 0.5 (box search)", 3.171,
                                       s2.greatest_lower.value));
  it = FourDigitItem("thm5.pi5", "Thm 5 upper bound on tr P, |da_M1| <= 0.1", 4.246, t5.pi5_printed);
  it.note = "Lemma (41) as printed: beta = " + Num(t5.lemma.beta_printed) + " (kappa = " + Num(t5.lemma.kappa) +
            " for unit eigenvectors, sigma = " + Num(t5.lemma.sigma) + ", |U_M|_s = " + Num(t5.lemma.UM_norm) +
            "); no reading found reproduces 4.246 (docs/papers/002.md); the sound Lemma bound |U_M|/2/(1 - x), x = " +
            Num(t5.lemma.x, 4) + ", gives beta = " + Num(t5.lemma.beta) + " and pi5 = " + Num(t5.pi5);
  report.items.push_back(it);
  report.items.push_back(
      FourDigitItem("thm5.least_upper", "max tr P over |da_M1| <= 0.1 (box search)", 3.450, sp.least_upper.value));
  report.items.push_back(
      FourDigitItem("thm6.pi6", "Thm 6 lower bound on tr P_F, |da_M1| <= 0.1", 2.506, Theorem6Bound(design, np)));
  report.items.push_back(FourDigitItem("thm6.greatest_lower", "min tr P_F over |da_M1| <= 0.1 (box search)", 3.390,
                                       sp.greatest_lower.value));

  auto where = [](const ErrorBoxExtreme& e, const std::string& name, double dv) {
    return name + " = " + Num(dv, 6) + (e.at_corner ? " (corner)" : " (interior)");
  };
  report.notes.push_back("nominal filter (q = 10, r = 5, a_1 = -1/3): tr P = tr P_F = " + Num(terms.nominal_trace, 6) +
                         "; true = model - Delta (002's sign)");
  report.notes.push_back("extremes: case 1 max tr P at " + where(s1.least_upper, "dq", s1.least_upper.errors.Q(0, 0)) +
                         ", min tr P_F at " + where(s1.greatest_lower, "dq", s1.greatest_lower.errors.Q(0, 0)) +
                         "; case 2 max at " + where(s2.least_upper, "dr", s2.least_upper.errors.R(0, 0)) + ", min at " +
                         where(s2.greatest_lower, "dr", s2.greatest_lower.errors.R(0, 0)));
  report.notes.push_back("plant errors: max tr P at " + where(sp.least_upper, "da_M1", sp.least_upper.errors.A(0, 0)) +
                         ", min tr P_F at " + where(sp.greatest_lower, "da_M1", sp.greatest_lower.errors.A(0, 0)));
  report.notes.push_back(
      "tolerance: half a unit of the paper's fourth digit; corrections to the printed formulas in "
      "docs/papers/002.md");
  return report;
}

}  // namespace kfx::detail
