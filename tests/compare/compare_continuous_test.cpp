// The methods added for continuous-time models and nested meshes (kfx/compare.hpp): `sampled:dt=h` on a
// continuous-time model file, the Kalman-Bucy reference, and `subspace:mesh=N` / `subspace61:mesh=N`,
// checked against the library calls they wrap (SampledFilterCovariance, SampledFilterEstimate,
// KalmanBucyCovariance, SolveFilterCare, the subspace filter from BuildDampedWave's subspace), against
// the Kalman filter (sampled at the data's grid it is the Kalman filter; every row is at least it and
// the Kalman-Bucy error below it), and Monte Carlo. Every bad spec and file class throws.
#include <gtest/gtest.h>

#include <cmath>

#include "kfx/compare.hpp"
#include "kfx/continuous.hpp"
#include "kfx/continuous_model_file.hpp"
#include "kfx/damped_wave.hpp"
#include "kfx/io.hpp"
#include "kfx/kalman_filter.hpp"
#include "kfx/simulation.hpp"
#include "kfx/subspace_filter.hpp"
#include "support/expect_error.hpp"
#include "support/file_testing.hpp"

namespace kfx {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;
using testing::ThrowsErrorStartingWith;

const std::string kOscillator = std::string(KFX_SOURCE_DIR) + "/examples/continuous/oscillator.json";
constexpr int kT = 40;  // steps of the data's grid dt = 0.05

double Rel(double a, double b) { return std::abs(a - b) / std::max(std::abs(b), 1e-300); }

std::vector<MethodSpec> Specs(const std::vector<std::string>& texts) {
  std::vector<MethodSpec> s;
  for (const auto& t : texts) s.push_back(ParseMethodSpec(t));
  return s;
}

class ContinuousCompareTest : public testing::TempDirTest {
 protected:
  void SetUp() override {
    TempDirTest::SetUp();
    truth_ = std::make_unique<ComparisonModel>(LoadComparisonModel(kOscillator));
  }
  std::unique_ptr<ComparisonModel> truth_;
};

TEST_F(ContinuousCompareTest, TheFileIsReadAsItsExactDiscreteEquivalent) {
  ASSERT_TRUE(truth_->continuous.has_value());
  const ContinuousModelFile& f = *truth_->continuous;
  EXPECT_EQ(f.dt, 0.05);
  EXPECT_EQ(truth_->model.state_dim(), 4);  // [z; int z]
  EXPECT_TRUE(truth_->model.time_invariant());
  const Model reference = SampledModel(f.model, 0.05 * kT, kT);
  const StepPtr a = truth_->model.step(7), b = reference.step(7);
  EXPECT_LT((a->A - b->A).norm() + (a->Q - b->Q).norm() + (a->R - b->R).norm(), 1e-15);
  const Model plain = LoadModelOrSampled(kOscillator);  // what `kfx filter` / `kfx simulate` read
  EXPECT_LT((plain.step(1)->Q - a->Q).norm(), 1e-15);
}

TEST_F(ContinuousCompareTest, SampledRowsAreTheLibrarysSampledFilterCovariance) {
  CompareOptions o;
  o.steps = kT;
  const std::vector<std::string> texts = {"kalman",         "sampled:dt=0.05", "sampled:0.1",
                                          "sampled:dt=0.2", "sampled:dt=0.4",  "sampled:dt=0.2,gain=steady"};
  const Comparison c = Compare(*truth_, Specs(texts), o);
  const ContinuousModel& cm = truth_->continuous->model;
  const double T = kT * 0.05;
  // At the data's grid the sampled filter is the Kalman filter: the library's P_{T,n} with n = T / dt.
  EXPECT_LT(Rel(c.kalman_final, SampledFilterCovariance(cm, T, kT).trace()), 1e-10);
  EXPECT_LT(Rel(c.rows[1].final_mse, c.kalman_final), 1e-10);
  const int every[] = {1, 1, 2, 4, 8};
  for (int i = 1; i <= 4; ++i) {
    const double library = SampledFilterCovariance(cm, T, kT / every[i]).trace();
    EXPECT_LT(Rel(c.rows[i].final_mse, library), 1e-9) << c.rows[i].spec;
    EXPECT_LT(Rel(c.rows[i].claimed_final, library), 1e-9) << c.rows[i].spec;
  }
  // Coarser sampling loses information: the error grows with h, and every row is at least the Kalman
  // filter's, which is at least the Kalman-Bucy filter's (KalmanBucyCovariance, paper 003).
  EXPECT_LT(c.rows[2].final_mse, c.rows[3].final_mse);
  EXPECT_LT(c.rows[3].final_mse, c.rows[4].final_mse);
  for (const CompareRow& r : c.rows) EXPECT_GE(r.final_mse, c.kalman_final * (1 - 1e-10)) << r.spec;
  EXPECT_LT(Rel(c.kalman_bucy_final, KalmanBucyCovariance(cm, T).trace()), 1e-12);
  EXPECT_LT(c.kalman_bucy_final, c.kalman_final);
  const CareSolution care = SolveFilterCare(cm);
  ASSERT_TRUE(care.summary.ok());
  EXPECT_LT(Rel(c.kalman_bucy_stationary, care.P.trace()), 1e-12);
  EXPECT_LT(c.kalman_bucy_stationary, c.kalman_stationary);
  // A schedule that ends between two updates claims its last covariance predicted to T.
  MethodOptions mo;
  mo.steps = 42;
  const ResolvedMethod m = ResolveMethod(ParseMethodSpec("sampled:dt=0.2"), *truth_, mo);
  PerformanceOptions po;
  po.steps = 42;
  po.weight = MatrixXd::Zero(4, 4);
  po.weight.topLeftCorner(2, 2).setIdentity();
  const double exact = ExactPerformance(truth_->model, *m.filter, po).weighted_mse(42);
  EXPECT_LT(Rel(m.claimed_cov.topLeftCorner(2, 2).trace(), exact), 1e-9);
}

TEST_F(ContinuousCompareTest, StationaryAndWeightedRows) {
  CompareOptions o;
  o.steps = kT;
  o.stationary = true;
  o.weight = (MatrixXd(2, 2) << 1, 0, 0, 0.25).finished();
  const Comparison c = Compare(*truth_, Specs({"kalman", "sampled:dt=0.05", "sampled:dt=0.1"}), o);
  EXPECT_LT(Rel(c.rows[1].stationary_mse, c.kalman_stationary), 1e-9);  // the steady gain at the data's grid
  EXPECT_TRUE(std::isnan(c.rows[2].stationary_mse));                    // periodic on the data's grid
  EXPECT_GE(c.rows[2].final_mse, c.rows[1].final_mse * (1 - 1e-10));
  const CareSolution care = SolveFilterCare(truth_->continuous->model);
  EXPECT_LT(Rel(c.kalman_bucy_stationary, (o.weight * care.P).trace()), 1e-12);
  EXPECT_LT(c.kalman_bucy_stationary, c.kalman_stationary);
}

TEST_F(ContinuousCompareTest, MonteCarloAgreesWithExactWithinItsInterval) {
  CompareOptions o;
  o.steps = kT;
  o.monte_carlo = 400;
  o.seed = 5;
  const Comparison c = Compare(*truth_, Specs({"sampled:dt=0.2", "sampled:dt=0.4,gain=steady"}), o);
  for (const CompareRow& r : c.rows) {
    EXPECT_EQ(r.mc_runs, 400);
    EXPECT_LT(std::abs(r.mc_mse - r.final_mse), 4 * r.mc_std_error) << r.spec;
  }
}

TEST_F(ContinuousCompareTest, OnDataTheSampledFilterIsTheLibrarysOnTheSummedIncrements) {
  const TimeSeries dy = Simulate(truth_->model, {kT, 9}).y;  // increments every dt
  MethodOptions mo;
  mo.steps = kT;
  for (int every : {1, 2, 4, 8}) {
    const std::string text = "sampled:dt=" + std::to_string(0.05 * every);
    const ResolvedMethod m = ResolveMethod(ParseMethodSpec(text), *truth_, mo);
    const TimeSeries x = m.run(dy);
    ASSERT_EQ(x.rows(), kT + 1);
    ASSERT_EQ(x.cols(), 4);
    TimeSeries coarse = TimeSeries::Zero(kT / every, 1);
    for (int k = 0; k < kT; ++k) coarse(k / every, 0) += dy(k, 0);
    const VectorXd library = SampledFilterEstimate(truth_->continuous->model, kT * 0.05, coarse);
    EXPECT_LT((x.row(kT).head(2).transpose() - library).norm(), 1e-10 * (1 + library.norm())) << text;
    if (every == 1) {  // the Kalman filter at the data's grid
      const TimeSeries kf = RunFilter(truth_->model, dy).x_filt;
      EXPECT_LT((x.leftCols(2) - kf.leftCols(2)).norm(), 1e-10 * (1 + kf.norm()));
    }
  }
}

TEST_F(ContinuousCompareTest, EveryBadSpecAndFileIsOneErrorNamingIt) {
  MethodOptions mo;
  mo.steps = 4;
  const ComparisonModel chain =
      LoadComparisonModel(std::string(KFX_SOURCE_DIR) + "/examples/models/mass_spring_chain.json");
  EXPECT_TRUE(ThrowsErrorStartingWith([&] { ResolveMethod(ParseMethodSpec("sampled:dt=0.1"), chain, mo); },
                                      "method 'sampled:dt=0.1': ", {"needs a continuous-time model"}));
  EXPECT_TRUE(ThrowsErrorStartingWith([&] { ResolveMethod(ParseMethodSpec("sampled:dt=0.07"), *truth_, mo); },
                                      "method 'sampled:dt=0.07': ", {"not a positive integer multiple of", "0.05"}));
  for (const char* bad : {"sampled:dt=0", "sampled:dt=-0.1", "sampled:dt=nan", "sampled:dt=inf", "sampled:dt=1x"}) {
    EXPECT_TRUE(ThrowsErrorStartingWith([&] { ParseMethodSpec(bad); },
                                        std::string("method '") + bad + "': ", {"dt: expected a finite number > 0"}));
  }
  EXPECT_TRUE(ThrowsErrorStartingWith([&] { ParseMethodSpec("sampled"); }, "method 'sampled': ", {"needs dt="}));
  EXPECT_TRUE(ThrowsErrorStartingWith([&] { ParseMethodSpec("sampled:dt=0.1,gain=converged"); },
                                      "method 'sampled:dt=0.1,gain=converged': ", {"gain: expected one of"}));
  CompareOptions o;
  o.weight = MatrixXd::Identity(4, 4);  // the weight of a continuous model is on z (2 x 2)
  EXPECT_TRUE(ThrowsErrorStartingWith([&] { Compare(*truth_, Specs({"kalman"}), o); }, "weight: ", {"2x2"}));
  const std::string head = R"({"format": "kfx-continuous-model", "A": [[0, 1], [-1, -0.4]], "C": [[1, 0]], )";
  const std::vector<std::pair<std::string, std::string>> files = {
      {head + R"("Q": [[0, 0], [0, 1]], "R": 0.1, "m0": [0, 0], "P0": [[1, 0], [0, 1]]})", "field 'dt': missing"},
      {head + R"("Q": [[0, 0], [0, 1]], "R": 0.1, "m0": [0, 0], "P0": [[1, 0], [0, 1]], "dt": 0})",
       "field 'dt': expected a finite number > 0"},
      {head + R"("Q": [[0, 0], [0, 1]], "R": 0, "m0": [0, 0], "P0": [[1, 0], [0, 1]], "dt": 0.1})",
       "field 'R': expected a positive definite"},
      {head + R"("Q": [[0, 0], [0, -1]], "R": 1, "m0": [0, 0], "P0": [[1, 0], [0, 1]], "dt": 0.1})",
       "field 'Q': expected a positive semidefinite"},
      {head + R"("R": 1, "m0": [0, 0], "P0": [[1, 0], [0, 1]], "dt": 0.1})", "field 'Q': missing"},
      {head + R"("Q": [[1]], "R": 1, "m0": [0, 0], "P0": [[1, 0], [0, 1]], "dt": 0.1})", "field 'Q': "},
  };
  for (std::size_t i = 0; i < files.size(); ++i) {
    const std::string path = Write("bad" + std::to_string(i) + ".json", files[i].first);
    EXPECT_TRUE(ThrowsErrorStartingWith([&] { LoadComparisonModel(path); }, path + ": ", {files[i].second}))
        << files[i].first;
    EXPECT_TRUE(ThrowsErrorStartingWith([&] { LoadModelOrSampled(path); }, path + ": ", {files[i].second}));
  }
}

// ---- subspace:mesh=N: nested P1 meshes of the damped-wave builder (000) ------------------------------

class MeshCompareTest : public testing::TempDirTest {};

TEST_F(MeshCompareTest, MeshSubspaceIsTheBuildersCoarseSpace) {
  DampedWaveOptions wo;
  wo.fine_nodes = 15;
  wo.coarse_nodes = 3;
  const DampedWaveProblem p = BuildDampedWave(wo);
  const ModelStep& s = p.fine.step;
  const ComparisonModel truth{Model(s, VectorXd::Zero(30), MatrixXd::Identity(30, 30)), std::nullopt, std::nullopt};
  CompareOptions o;
  o.steps = 30;
  o.weight = p.fine.gram;
  WriteNpyMatrix(Path("E.npy"), p.prolongation);
  WriteNpyMatrix(Path("W.npy"), p.fine.gram);
  const Comparison c =
      Compare(truth,
              Specs({"subspace:mesh=3", "subspace:basis=" + Path("E.npy") + ",gram=" + Path("W.npy"), "subspace:mesh=7",
                     "subspace61:mesh=3", "subspace61:basis=" + Path("E.npy") + ",gram=" + Path("W.npy")}),
              o);
  // The library run on the builder's subspace (000 Algorithm 2.3), evaluated by the engine.
  SubspaceFilterOptions so;
  so.steps = 30;
  so.store_schedule = true;
  const SubspaceFilterSchedule sch = ComputeSubspaceFilterSchedule(s, truth.model.P0(), p.subspace, so);
  PerformanceOptions po;
  po.steps = 30;
  po.weight = p.fine.gram;
  const double library =
      ExactPerformance(truth.model, SubspaceFilterAsLinearFilter(s, p.subspace, sch, truth.model.m0()), po)
          .weighted_mse(30);
  EXPECT_LT(Rel(c.rows[0].final_mse, library), 1e-10);
  EXPECT_LT(Rel(c.rows[1].final_mse, library), 1e-10);
  EXPECT_LT(Rel(c.rows[3].final_mse, c.rows[4].final_mse), 1e-10);
  EXPECT_EQ(c.rows[0].state_dim, 6);
  EXPECT_EQ(c.rows[2].state_dim, 14);
  for (const CompareRow& r : c.rows) EXPECT_GE(r.final_mse, c.kalman_final * (1 - 1e-10)) << r.spec;
  MethodOptions mo;
  mo.steps = 30;
  for (const auto& [spec, what] : std::vector<std::pair<std::string, std::string>>{
           {"subspace:mesh=4", "the meshes are not nested"},
           {"subspace61:mesh=15", "the meshes are not nested"},
           {"subspace:mesh=3,gram=" + Path("E.npy"), "gram: expected a 30x30 matrix"}}) {
    const std::string text = spec;  // C++17: a lambda cannot capture a structured binding (clang rejects it)
    EXPECT_TRUE(ThrowsErrorStartingWith([&] { ResolveMethod(ParseMethodSpec(text), truth, mo); },
                                        "method '" + text + "': ", {what}))
        << text;
  }
  const ComparisonModel odd{Model(MakeStep(MatrixXd::Identity(3, 3) * 0.5, MatrixXd::Ones(1, 3),
                                           MatrixXd::Identity(3, 3), MatrixXd::Identity(1, 1)),
                                  VectorXd::Zero(3), MatrixXd::Identity(3, 3)),
                            std::nullopt, std::nullopt};
  EXPECT_TRUE(ThrowsErrorStartingWith([&] { ResolveMethod(ParseMethodSpec("subspace:mesh=1"), odd, mo); },
                                      "method 'subspace:mesh=1': ", {"n even"}));
  for (const char* bad : {"subspace:mesh=3,basis=E.npy", "subspace", "subspace61:gram=W.npy", "subspace:mesh=0"}) {
    EXPECT_TRUE(ThrowsErrorStartingWith([&] { ParseMethodSpec(bad); }, std::string("method '") + bad + "': ")) << bad;
  }
}

}  // namespace
}  // namespace kfx
