// kfx::Compare and ResolveMethod (kfx/compare.hpp) on the bundled 4-mass chain (n = 8, m = 2) and a small
// coupled model, checked against independent truths: the Kalman filter's Riccati recursion and DARE,
// the reduced-order filters at full order (= the Kalman predictor and filter), the subspace-optimal
// filter on the whole space (= the Kalman filter), Monte Carlo within its interval, and each method's
// online implementation against RunLinearFilter on its LinearFilter. Every bad spec class throws.
#include "kfx/compare.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "kfx/coupled_model_file.hpp"
#include "kfx/io.hpp"
#include "kfx/kalman_filter.hpp"
#include "kfx/riccati.hpp"
#include "kfx/simulation.hpp"
#include "support/expect_error.hpp"
#include "support/file_testing.hpp"

namespace kfx {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;
using testing::ThrowsErrorStartingWith;

const std::string kChain = std::string(KFX_SOURCE_DIR) + "/examples/models/mass_spring_chain.json";
constexpr int kT = 40;

double Rel(double a, double b) { return std::abs(a - b) / std::max(std::abs(b), 1e-300); }

class CompareTest : public testing::TempDirTest {
 protected:
  void SetUp() override {
    TempDirTest::SetUp();
    truth_ = std::make_unique<ComparisonModel>(LoadComparisonModel(kChain));
    WriteNpyMatrix(Path("I.npy"), MatrixXd::Identity(8, 8));
    WriteNpyMatrix(Path("E3.npy"), MatrixXd::Identity(8, 3));
  }
  std::vector<MethodSpec> Specs(const std::vector<std::string>& texts) {
    std::vector<MethodSpec> s;
    for (const auto& t : texts) s.push_back(ParseMethodSpec(t));
    return s;
  }
  std::unique_ptr<ComparisonModel> truth_;
};

TEST_F(CompareTest, KalmanRowsEqualTheRiccatiRecursionAndTheDare) {
  CompareOptions o;
  o.steps = kT;
  const Comparison c = Compare(*truth_, Specs({"kalman", "kalman:form=standard", "steady"}), o);
  KalmanScheduleOptions ko;
  ko.steps = kT;
  const KalmanSchedule sch = ComputeKalmanSchedule(truth_->model, ko);
  const StepPtr step_ptr = truth_->model.step(1);
  const ModelStep& s = *step_ptr;
  const DareSolution dare = SolveFilterDare(s.A, s.C, s.Q, s.R);
  EXPECT_LT(Rel(c.kalman_final, sch.P_filt[kT].trace()), 1e-12);
  EXPECT_LT(Rel(c.kalman_stationary, dare.P_filt.trace()), 1e-12);
  for (int i = 0; i < 2; ++i) {
    EXPECT_LT(Rel(c.rows[i].final_mse, sch.P_filt[kT].trace()), 1e-8) << c.rows[i].spec;
    EXPECT_LT(Rel(c.rows[i].claimed_final, sch.P_filt[kT].trace()), 1e-8);
    EXPECT_NEAR(c.rows[i].ratio, 1.0, 1e-8);
    EXPECT_EQ(c.rows[i].online, "RunFilter");
  }
  EXPECT_LT(Rel(c.rows[2].stationary_mse, dare.P_filt.trace()), 1e-8);
  EXPECT_LT(Rel(c.rows[2].claimed_stationary, dare.P_filt.trace()), 1e-12);
  EXPECT_GE(c.rows[2].final_mse, c.kalman_final * (1 - 1e-10));
}

TEST_F(CompareTest, FullOrderReducedFiltersAndWholeSpaceSubspaceFilterAreTheKalmanFilter) {
  CompareOptions o;
  o.steps = kT;
  const Comparison c =
      Compare(*truth_, Specs({"tau:order=8", "tau:order=8,step=two-da", "subspace:basis=" + Path("I.npy")}), o);
  KalmanScheduleOptions ko;
  ko.steps = kT;
  const KalmanSchedule sch = ComputeKalmanSchedule(truth_->model, ko);
  EXPECT_LT(Rel(c.rows[0].final_mse, sch.P_pred[kT].trace()), 1e-6);  // the one-step filter predicts
  EXPECT_LT(Rel(c.rows[1].final_mse, sch.P_filt[kT].trace()), 1e-6);
  EXPECT_LT(Rel(c.rows[2].final_mse, sch.P_filt[kT].trace()), 1e-6);
  EXPECT_LT(Rel(c.rows[2].claimed_final, sch.P_filt[kT].trace()), 1e-6);
}

TEST_F(CompareTest, ExactMseIsTheWrappedLibraryCallAndEveryRowIsAtLeastTheKalmanFilters) {
  SaveModel(Path("same.json"), truth_->model);
  const std::vector<std::string> texts = {"kalman",
                                          "design:" + Path("same.json"),
                                          "coarse:model=" + Path("same.json") + ",prolongation=" + Path("I.npy"),
                                          "tau:order=4",
                                          "tau:order=4,step=two-forecast",
                                          "tau:basis=" + Path("E3.npy") + ",step=two-da",
                                          "mu:order=4",
                                          "mu:order=4,step=two-da",
                                          "subspace:basis=" + Path("E3.npy"),
                                          "subspace:basis=" + Path("E3.npy") + ",gain=converged",
                                          "subspace61:basis=" + Path("E3.npy")};
  CompareOptions o;
  o.steps = kT;
  o.weight = MatrixXd::Identity(8, 8);
  o.weight.diagonal().tail(4).setConstant(0.25);  // velocities weigh less
  const Comparison c = Compare(*truth_, Specs(texts), o);
  ASSERT_EQ(c.rows.size(), texts.size());
  MethodOptions mo;
  mo.steps = kT;
  PerformanceOptions po;
  po.steps = kT;
  po.weight = o.weight;
  for (const CompareRow& r : c.rows) {
    const ResolvedMethod m = ResolveMethod(ParseMethodSpec(r.spec), *truth_, mo);
    const PerformanceResult exact = ExactPerformance(truth_->model, *m.filter, po);
    EXPECT_LT(Rel(r.final_mse, exact.weighted_mse(kT)), 1e-12) << r.spec;
    EXPECT_GE(r.final_mse, c.kalman_final * (1 - 1e-9)) << r.spec;
    EXPECT_EQ(r.state_dim, m.filter->state_dim());
    EXPECT_GT(r.memory_bytes, 0);
    EXPECT_GT(r.online_seconds_per_step, 0);
  }
  // A filter designed on the true model is the steady-state filter; so is the coarse filter with E = I.
  EXPECT_LT(Rel(c.rows[1].stationary_mse, c.kalman_stationary), 1e-8);
  EXPECT_LT(Rel(c.rows[2].stationary_mse, c.kalman_stationary), 1e-8);
}

TEST_F(CompareTest, StationaryRowsAreAtLeastTheDare) {
  CompareOptions o;
  o.stationary = true;
  const std::string e3 = Path("E3.npy");
  const Comparison c =
      Compare(*truth_, Specs({"kalman", "subspace:basis=" + e3, "subspace61:basis=" + e3, "tau:order=4"}), o);
  EXPECT_LT(Rel(c.rows[0].stationary_mse, c.kalman_stationary), 1e-8);
  EXPECT_NEAR(c.rows[0].ratio, 1.0, 1e-8);
  EXPECT_GT(c.rows[1].stationary_mse, c.kalman_stationary);
  EXPECT_GT(c.rows[2].stationary_mse, c.kalman_stationary);
  EXPECT_TRUE(std::isnan(c.rows[3].stationary_mse));  // a finite-horizon schedule has no stationary value
  EXPECT_FALSE(c.rows[3].stationary_note.empty());
}

TEST_F(CompareTest, MonteCarloAgreesWithExactWithinItsInterval) {
  CompareOptions o;
  o.steps = 20;
  o.monte_carlo = 400;
  o.seed = 11;
  const Comparison c = Compare(*truth_, Specs({"steady", "tau:order=4,step=two-da", "mu:order=2"}), o);
  for (const CompareRow& r : c.rows) {
    EXPECT_EQ(r.mc_runs, 400);
    EXPECT_LT(std::abs(r.mc_mse - r.final_mse), 4 * r.mc_std_error) << r.spec;
  }
}

TEST_F(CompareTest, OnlineImplementationsEqualTheLinearFilterRun) {
  const TimeSeries y = Simulate(truth_->model, {kT, 5}).y;
  MethodOptions mo;
  mo.steps = kT;
  const std::vector<std::string> texts = {
      "kalman",      "kalman:form=standard",         "steady",
      "tau:order=4", "mu:order=4,step=two-forecast", "subspace:basis=" + Path("E3.npy")};
  for (const std::string& t : texts) {
    const ResolvedMethod m = ResolveMethod(ParseMethodSpec(t), *truth_, mo);
    const TimeSeries own = m.run(y);
    const TimeSeries lin = RunLinearFilter(*m.filter, y);
    EXPECT_LT((own - lin).norm(), 1e-8 * (1 + lin.norm())) << t;
  }
}

CoupledSystem SmallCoupled() {
  MatrixXd F(2, 2), H(1, 2), V = 0.05 * MatrixXd::Identity(2, 2), R = 0.1 * MatrixXd::Identity(1, 1), g(2, 1);
  F << 0.9, 0.1, -0.1, 0.8;
  H << 1, 0;
  g << 1, 0.5;
  const CoupledStep s = MakeIdenticalCoupledStep(4, F, H, V, R, g, 0.3 * MatrixXd::Identity(1, 1));
  return CoupledSystem(s, VectorXd::Zero(8), MatrixXd::Identity(2, 2).replicate(1, 4));
}

TEST_F(CompareTest, CoupledFiltersFromACoupledModelFile) {
  SaveCoupledModel(Path("coupled.json"), SmallCoupled());
  const ComparisonModel truth = LoadComparisonModel(Path("coupled.json"));
  ASSERT_TRUE(truth.coupled.has_value());
  CompareOptions o;
  o.steps = 30;
  const Comparison c = Compare(truth, Specs({"blockdiag", "banded", "kalman"}), o);
  CoupledFilterOptions co;
  co.steps = 30;
  PerformanceOptions po;
  po.steps = 30;
  const PerformanceResult exact = ExactPerformance(
      truth.model, CoupledFilterAsLinearFilter(*truth.coupled, CoupledFilterKind::kBlockDiagonal, co), po);
  EXPECT_LT(Rel(c.rows[0].final_mse, exact.mse(30)), 1e-12);
  EXPECT_EQ(c.rows[0].online, "RunCoupledFilter");
  EXPECT_GT(c.rows[0].final_mse, c.kalman_final);
  EXPECT_GE(c.rows[1].final_mse, c.kalman_final * (1 - 1e-9));
  EXPECT_LT(Rel(c.rows[2].final_mse, c.kalman_final), 1e-8);
  const TimeSeries y = SimulateCoupled(*truth.coupled, {30, 3}).y;
  MethodOptions mo;
  mo.steps = 30;
  for (const char* t : {"blockdiag", "banded"}) {
    const ResolvedMethod m = ResolveMethod(ParseMethodSpec(t), truth, mo);
    const TimeSeries lin = RunLinearFilter(*m.filter, y);
    EXPECT_LT((m.run(y) - lin).norm(), 1e-9 * (1 + lin.norm())) << t;
  }
}

TEST_F(CompareTest, AModelWithAKnownInputIsAnErrorNamingModel) {
  ModelStep s = *truth_->model.step(1);
  s.G = MatrixXd::Ones(s.state_dim(), 1);
  const ComparisonModel driven{Model(s, truth_->model.m0(), truth_->model.P0()), std::nullopt, std::nullopt};
  EXPECT_TRUE(
      testing::ThrowsErrorNaming([&] { Compare(driven, {ParseMethodSpec("kalman")}); }, "model", {"known input"}));
}

TEST_F(CompareTest, EveryBadSpecAgainstTheModelIsOneErrorNamingIt) {
  WriteNpyMatrix(Path("wrong.npy"), MatrixXd::Identity(7, 2));
  WriteNpyMatrix(Path("Lwide.npy"), MatrixXd::Identity(2, 9));
  const ModelStep s = *truth_->model.step(1);
  const ComparisonModel varying{Model(std::vector<ModelStep>{s, s, s}, truth_->model.m0(), truth_->model.P0()),
                                std::nullopt, std::nullopt};
  MethodOptions mo;
  mo.steps = 3;
  const std::vector<std::pair<std::string, std::string>> bad = {
      {"tau:order=9", "order 9 is larger than the state dimension 8"},
      {"mu:order=8", "must be smaller than the state dimension 8"},
      {"tau:basis=" + Path("wrong.npy"), "basis: expected a basis with 8 rows"},
      {"subspace:basis=" + Path("wrong.npy"), "basis: expected a basis with 8 rows"},
      {"tau:weight=" + Path("Lwide.npy"), "weight: expected an L with 8 columns"},
      {"tau:order=2,basis=" + Path("E3.npy"), "order=2 differs from the columns of basis (3)"},
      {"subspace:basis=" + Path("E3.npy") + ",gram=" + Path("E3.npy"), "gram: expected a 8x8 matrix"},
      {"subspace61:basis=" + Path("missing.npy"), "basis: "},
      {"blockdiag", "needs a coupled model"},
      {"banded", "needs a coupled model"},
      {"design:" + Path("missing.json"), "model: "},
      {"coarse:model=" + kChain + ",prolongation=" + Path("E3.npy"), "prolongation: expected a 8x8 matrix"},
  };
  for (const auto& [spec, what] : bad) {
    const std::string text = spec;  // C++17: a lambda cannot capture a structured binding (clang rejects it)
    EXPECT_TRUE(ThrowsErrorStartingWith([&] { ResolveMethod(ParseMethodSpec(text), *truth_, mo); },
                                        "method '" + text + "': ", {what}))
        << text;
  }
  EXPECT_TRUE(ThrowsErrorStartingWith([&] { ResolveMethod(ParseMethodSpec("steady"), varying, mo); },
                                      "method 'steady': ", {"time-invariant"}));
  CompareOptions o;
  o.weight = MatrixXd::Identity(3, 3);
  EXPECT_TRUE(ThrowsErrorStartingWith([&] { Compare(*truth_, Specs({"steady"}), o); }, "weight: "));
  o = CompareOptions();
  o.monte_carlo = 1;
  EXPECT_TRUE(ThrowsErrorStartingWith([&] { Compare(*truth_, Specs({"steady"}), o); }, "monte_carlo: "));
}

}  // namespace
}  // namespace kfx
