// Tests of src/io/model_file.cpp: LoadModel / SaveModel and the bundled examples/models/.
// Oracles: hand-written files with known matrices, bit-for-bit round trips, every error path, and
// for the mass-spring chain an independent discretization (Eigen's matrix exponential).
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <unsupported/Eigen/MatrixFunctions>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include <unistd.h>

#include "kfx/continuous_model_file.hpp"
#include "kfx/error.hpp"
#include "kfx/io.hpp"
#include "kfx/model.hpp"
#include "kfx/riccati.hpp"
#include "support/expect_error.hpp"
#include "support/matrix_testing.hpp"

namespace kfx {
namespace {

namespace fs = std::filesystem;
using kfx::testing::TestRng;

bool SameBits(const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  return a.rows() == b.rows() && a.cols() == b.cols() &&
         (a.size() == 0 || std::memcmp(a.data(), b.data(), sizeof(double) * static_cast<std::size_t>(a.size())) == 0);
}

// Every matrix of every step, the prior, the horizon and the kind agree bit for bit.
::testing::AssertionResult ModelsIdentical(const Model& a, const Model& b, int steps) {
  if (a.state_dim() != b.state_dim() || a.meas_dim() != b.meas_dim()) return ::testing::AssertionFailure() << "dims";
  if (a.time_invariant() != b.time_invariant()) return ::testing::AssertionFailure() << "time_invariant";
  if (a.horizon() != b.horizon()) {
    return ::testing::AssertionFailure() << "horizon " << a.horizon() << " vs " << b.horizon();
  }
  if (!SameBits(a.m0(), b.m0())) return ::testing::AssertionFailure() << "m0";
  if (!SameBits(a.P0(), b.P0())) return ::testing::AssertionFailure() << "P0";
  for (int k = 1; k <= steps; ++k) {
    const StepPtr s = a.step(k), t = b.step(k);
    const std::pair<const char*, std::pair<const Eigen::MatrixXd*, const Eigen::MatrixXd*>> fields[] = {
        {"A", {&s->A, &t->A}}, {"C", {&s->C, &t->C}}, {"Q", {&s->Q, &t->Q}},
        {"R", {&s->R, &t->R}}, {"B", {&s->B, &t->B}}, {"U", {&s->U, &t->U}}};
    for (const auto& [name, mats] : fields) {
      if (!SameBits(*mats.first, *mats.second)) {
        return ::testing::AssertionFailure() << "step " << k << ": " << name << " differs:\n"
                                             << *mats.first << "\nvs\n"
                                             << *mats.second;
      }
    }
  }
  return ::testing::AssertionSuccess();
}

class ModelFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() / ("kfx_model_file_test_" + std::to_string(::getpid()) + "_" + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }
  std::string Write(const std::string& name, const std::string& text) const {
    const std::string path = Path(name);
    fs::create_directories(fs::path(path).parent_path());
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out << text;
    return path;
  }
  // Writes a model file with the given JSON body and expects LoadModel to fail with every text.
  void ExpectLoadError(const std::string& json, const std::vector<std::string>& texts) {
    const std::string path = Write("bad.json", json);
    ExpectLoadErrorAt(path, texts);
  }
  static void ExpectLoadErrorAt(const std::string& path, const std::vector<std::string>& texts) {
    EXPECT_TRUE(testing::ThrowsErrorStartingWith([&] { LoadModel(path); }, path + ": ", texts));
  }

  fs::path dir_;
};

// The fields of a valid 2-state model, to be combined with one broken field.
const std::string kCvFields = R"("A": [[1, 1], [0, 1]], "C": [[1, 0]], "Q": [[0.25, 0.5], [0.5, 1]], "R": 2,
  "m0": [0, 0], "P0": [[10, 0], [0, 10]])";

TEST_F(ModelFileTest, LoadsInlineModel) {
  const Model model = LoadModel(Write("cv.json", R"({
    "format": "kfx-model", "version": 1, "name": "cv", "description": "test",
    "A": [[1, 1], [0, 1]], "C": [[1, 0]], "Q": [[0.25, 0.5], [0.5, 1.0]], "R": 0.5,
    "m0": [1, -2], "P0": [[10, 0], [0, 10]], "some_future_field": {"x": 1}
  })"));
  EXPECT_TRUE(model.time_invariant());
  EXPECT_EQ(model.horizon(), -1);
  EXPECT_EQ(model.state_dim(), 2);
  EXPECT_EQ(model.meas_dim(), 1);
  const StepPtr s = model.step(1);
  EXPECT_MATRICES_NEAR(s->A, (Eigen::MatrixXd(2, 2) << 1, 1, 0, 1).finished(), 0.0);
  EXPECT_MATRICES_NEAR(s->C, (Eigen::MatrixXd(1, 2) << 1, 0).finished(), 0.0);
  EXPECT_MATRICES_NEAR(s->Q, (Eigen::MatrixXd(2, 2) << 0.25, 0.5, 0.5, 1).finished(), 0.0);
  EXPECT_MATRICES_NEAR(s->R, Eigen::MatrixXd::Constant(1, 1, 0.5), 0.0);
  EXPECT_EQ(s->B.size(), 0);
  EXPECT_MATRICES_NEAR(model.m0(), Eigen::Vector2d(1, -2), 0.0);
  EXPECT_MATRICES_NEAR(model.P0(), 10.0 * Eigen::MatrixXd::Identity(2, 2), 0.0);
}

TEST_F(ModelFileTest, FormatAndVersionAreOptional) {
  const Model model = LoadModel(Write("m.json", "{" + kCvFields + "}"));
  EXPECT_EQ(model.state_dim(), 2);
}

TEST_F(ModelFileTest, ScalarsAndColumnVectors) {
  const Model model = LoadModel(Write("s.json", R"({"A": 0.9, "C": 1, "Q": 0.1, "R": [[0.2]], "m0": 3, "P0": 1})"));
  EXPECT_EQ(model.state_dim(), 1);
  EXPECT_EQ(model.step(1)->A(0, 0), 0.9);
  EXPECT_EQ(model.m0()(0), 3.0);
  const Model col = LoadModel(Write("c.json", R"({"A": [[1, 1], [0, 1]], "C": [[1, 0]], "Q": [[1, 0], [0, 1]], "R": 1,
      "m0": [[4], [5]], "P0": [[1, 0], [0, 1]]})"));
  EXPECT_MATRICES_NEAR(col.m0(), Eigen::Vector2d(4, 5), 0.0);
}

TEST_F(ModelFileTest, NoiseInputGivesQ) {
  const Model model = LoadModel(Write("bu.json", R"({"A": [[1, 0.1], [0, 1]], "B": [[0.005], [0.1]], "U": 4,
      "C": [[1, 0]], "R": 0.01, "m0": [0, 0], "P0": [[1, 0], [0, 1]]})"));
  const StepPtr s = model.step(1);
  Eigen::MatrixXd b(2, 1);
  b << 0.005, 0.1;
  EXPECT_MATRICES_NEAR(s->B, b, 0.0);
  EXPECT_MATRICES_NEAR(s->U, Eigen::MatrixXd::Constant(1, 1, 4.0), 0.0);
  EXPECT_MATRICES_NEAR(s->Q, 4.0 * b * b.transpose(), 1e-18);
  // Q may be given as well; it must agree with B U B^T.
  const Model with_q =
      LoadModel(Write("buq.json", R"({"A": 1, "B": 2, "U": 3, "Q": 12, "C": 1, "R": 1, "m0": 0, "P0": 1})"));
  EXPECT_EQ(with_q.step(1)->Q(0, 0), 12.0);
  ExpectLoadError(R"({"A": 1, "B": 2, "U": 3, "Q": 11, "C": 1, "R": 1, "m0": 0, "P0": 1})",
                  {"field 'Q': expected Q = B U B^T"});
}

TEST_F(ModelFileTest, NpyReferencesAreRelativeToTheModelFile) {
  fs::create_directories(Path("sub/data"));
  Eigen::MatrixXd a(2, 2);
  a << 0.9, 0.1, -0.1, 0.9;
  WriteNpyMatrix(Path("sub/data/A.npy"), a);
  WriteNpyVector(Path("sub/m0.npy"), Eigen::Vector2d(1, 2));
  const double r = 0.5;
  WriteNpy(Path("sub/r.npy"), {}, &r);  // 0-d: a 1x1 matrix
  const std::string path = Write("sub/model.json", R"({"A": {"npy": "data/A.npy"}, "C": [[1, 0]],
      "Q": [[1, 0], [0, 1]], "R": {"npy": "r.npy"}, "m0": {"npy": "m0.npy"}, "P0": [[1, 0], [0, 1]]})");
  const Model model = LoadModel(path);
  EXPECT_MATRICES_NEAR(model.step(1)->A, a, 0.0);
  EXPECT_EQ(model.step(1)->R(0, 0), 0.5);
  EXPECT_MATRICES_NEAR(model.m0(), Eigen::Vector2d(1, 2), 0.0);
  // Absolute paths work too.
  const Model absolute = LoadModel(Write("abs.json", R"({"A": {"npy": ")" + Path("sub/data/A.npy") +
                                                         R"("}, "C": [[1, 0]], "Q": [[1, 0], [0, 1]], "R": 1,
      "m0": [0, 0], "P0": [[1, 0], [0, 1]]})"));
  EXPECT_MATRICES_NEAR(absolute.step(1)->A, a, 0.0);
}

TEST_F(ModelFileTest, TimeVaryingInlineFieldsRepeatConstantOnes) {
  const Model model = LoadModel(Write("tv.json", R"({"A": [[[1]], [[0.5]], [[0.25]]], "C": 1, "Q": 0.1,
      "R": [[[1]], [[2]], [[3]]], "m0": 0, "P0": 1, "horizon": 3})"));
  EXPECT_FALSE(model.time_invariant());
  EXPECT_EQ(model.horizon(), 3);
  for (int k = 1; k <= 3; ++k) {
    EXPECT_EQ(model.step(k)->A(0, 0), std::pow(0.5, k - 1));
    EXPECT_EQ(model.step(k)->R(0, 0), k);
    EXPECT_EQ(model.step(k)->Q(0, 0), 0.1);
  }
  EXPECT_THROW(model.step(4), Error);
}

TEST_F(ModelFileTest, TimeVaryingFrom3dNpy) {
  const int T = 4;
  std::vector<double> c(static_cast<std::size_t>(T) * 1 * 2);
  for (int k = 0; k < T; ++k) {
    c[2 * k] = 1.0;
    c[2 * k + 1] = 0.1 * k;
  }
  WriteNpy(Path("C.npy"), {T, 1, 2}, c.data());
  const Model model = LoadModel(Write("tv.json", R"({"A": [[1, 1], [0, 1]], "C": {"npy": "C.npy"},
      "Q": [[1, 0], [0, 1]], "R": 1, "m0": [0, 0], "P0": [[1, 0], [0, 1]]})"));
  EXPECT_EQ(model.horizon(), T);
  EXPECT_EQ(model.step(3)->C(0, 1), 0.2);
}

TEST_F(ModelFileTest, HorizonMakesAnInvariantModelASequence) {
  const Model model = LoadModel(Write("h.json", "{" + kCvFields + R"(, "horizon": 5})"));
  EXPECT_FALSE(model.time_invariant());
  EXPECT_EQ(model.horizon(), 5);
  EXPECT_TRUE(SameBits(model.step(5)->Q, model.step(1)->Q));
}

// ----- Round trips ----------------------------------------------------------------------------

ModelStep RandomStep(TestRng& rng, Eigen::Index n, Eigen::Index m, Eigen::Index p) {
  if (p > 0) {
    // One draw per statement, in GCC's former order of the arguments (TestRng).
    Eigen::MatrixXd R = rng.Spd(m);
    Eigen::MatrixXd C = rng.Gaussian(m, n);
    Eigen::MatrixXd U = rng.Spd(p);
    Eigen::MatrixXd B = rng.Gaussian(n, p);
    Eigen::MatrixXd A = rng.WithSpectralRadius(n, 0.9);
    return MakeStepWithNoiseInput(std::move(A), std::move(B), std::move(U), std::move(C), std::move(R));
  }
  return RandomModelStep(rng, n, m, 0.9);
}

TEST_F(ModelFileTest, RoundTripTimeInvariantIsBitwise) {
  TestRng rng(1);
  const Eigen::MatrixXd P0 = rng.Spd(3);  // one draw per statement, in GCC's former order of the arguments
  const Eigen::VectorXd x0 = rng.Gaussian(3, 1);
  const Model model(RandomStep(rng, 3, 2, 0), x0, P0);
  SaveModel(Path("m.json"), model);
  EXPECT_TRUE(ModelsIdentical(LoadModel(Path("m.json")), model, 1));
  // Small model: everything inline.
  EXPECT_FALSE(fs::exists(Path("m.A.npy")));
}

TEST_F(ModelFileTest, RoundTripLargeMatricesGoToNpy) {
  TestRng rng(2);
  const Eigen::MatrixXd P0 = rng.Spd(25);  // one draw per statement, in GCC's former order of the arguments
  const Eigen::VectorXd x0 = rng.Gaussian(25, 1);
  const Model model(RandomStep(rng, 25, 3, 0), x0, P0);
  SaveModel(Path("big.json"), model);  // 625 entries > inline_max_entries = 400
  EXPECT_TRUE(fs::exists(Path("big.A.npy")));
  EXPECT_TRUE(fs::exists(Path("big.Q.npy")));
  EXPECT_TRUE(fs::exists(Path("big.P0.npy")));
  EXPECT_FALSE(fs::exists(Path("big.C.npy")));  // 75 entries
  EXPECT_FALSE(fs::exists(Path("big.m0.npy")));
  EXPECT_TRUE(ModelsIdentical(LoadModel(Path("big.json")), model, 1));
  // Everything to .npy.
  SaveModelOptions options;
  options.inline_max_entries = 0;
  SaveModel(Path("all.json"), model, options);
  for (const char* f : {"A", "C", "Q", "R", "m0", "P0"})
    EXPECT_TRUE(fs::exists(Path(std::string("all.") + f + ".npy"))) << f;
  EXPECT_TRUE(ModelsIdentical(LoadModel(Path("all.json")), model, 1));
}

TEST_F(ModelFileTest, RoundTripNoiseInputIsBitwise) {
  TestRng rng(3);
  const Eigen::MatrixXd P0 = rng.Spd(4);  // one draw per statement, in GCC's former order of the arguments
  const Eigen::VectorXd x0 = rng.Gaussian(4, 1);
  const Model model(RandomStep(rng, 4, 2, 2), x0, P0);
  SaveModel(Path("bu.json"), model);
  const Model back = LoadModel(Path("bu.json"));
  EXPECT_TRUE(ModelsIdentical(back, model, 1));
  EXPECT_EQ(back.step(1)->B.cols(), 2);
  // A Q that agrees with B U B^T only to rounding is written out, so that it survives too.
  ModelStep s = *model.step(1);
  s.Q(0, 0) *= 1.0 + 1e-14;
  s.Q(1, 1) *= 1.0 - 1e-14;
  const Model nudged(s, model.m0(), model.P0());
  SaveModel(Path("buq.json"), nudged);
  EXPECT_TRUE(ModelsIdentical(LoadModel(Path("buq.json")), nudged, 1));
}

TEST_F(ModelFileTest, RoundTripTimeVaryingIsBitwise) {
  TestRng rng(4);
  const int T = 6;
  const ModelStep base = RandomStep(rng, 3, 2, 0);
  std::vector<ModelStep> steps;
  for (int k = 0; k < T; ++k) {
    ModelStep s = base;  // C and R constant, A and Q time-varying
    s.A = rng.WithSpectralRadius(3, 0.8);
    s.Q = rng.Spd(3);
    steps.push_back(s);
  }
  const Eigen::MatrixXd P0 = rng.Spd(3);  // one draw per statement, in GCC's former order of the arguments
  const Eigen::VectorXd x0 = rng.Gaussian(3, 1);
  const Model model(steps, x0, P0);
  SaveModel(Path("tv.json"), model);
  EXPECT_FALSE(fs::exists(Path("tv.A.npy")));  // 54 entries: inline
  EXPECT_TRUE(ModelsIdentical(LoadModel(Path("tv.json")), model, T));
  SaveModelOptions options;
  options.inline_max_entries = 20;  // A and Q (54 entries) as (T, 3, 3) .npy, C and R inline
  SaveModel(Path("tvn.json"), model, options);
  EXPECT_EQ(ReadNpy(Path("tvn.A.npy")).shape, (std::vector<std::int64_t>{T, 3, 3}));
  EXPECT_FALSE(fs::exists(Path("tvn.C.npy")));
  EXPECT_TRUE(ModelsIdentical(LoadModel(Path("tvn.json")), model, T));
  // Fewer steps on request.
  options.steps = 2;
  SaveModel(Path("tv2.json"), model, options);
  const Model two = LoadModel(Path("tv2.json"));
  EXPECT_EQ(two.horizon(), 2);
  EXPECT_TRUE(SameBits(two.step(2)->A, model.step(2)->A));
}

TEST_F(ModelFileTest, RoundTripTimeVaryingNoiseInputIsBitwise) {
  TestRng rng(5);
  const int T = 5;
  std::vector<ModelStep> steps;
  const Eigen::MatrixXd A = rng.WithSpectralRadius(4, 0.9);
  for (int k = 0; k < T; ++k) {
    // A constant, B and U time-varying: Q follows.
    // One draw per statement, in GCC's former order of the arguments (TestRng).
    Eigen::MatrixXd R = rng.Spd(1);
    Eigen::MatrixXd C = rng.Gaussian(1, 4);
    Eigen::MatrixXd U = rng.Spd(2);
    Eigen::MatrixXd B = rng.Gaussian(4, 2);
    steps.push_back(MakeStepWithNoiseInput(A, std::move(B), std::move(U), std::move(C), std::move(R)));
  }
  const Model model(steps, Eigen::VectorXd::Zero(4), Eigen::MatrixXd::Identity(4, 4));
  SaveModelOptions options;
  options.inline_max_entries = 16;
  SaveModel(Path("tvbu.json"), model, options);
  EXPECT_TRUE(fs::exists(Path("tvbu.B.npy")));
  EXPECT_FALSE(fs::exists(Path("tvbu.Q.npy")));  // recomputed exactly from B, U on load
  EXPECT_TRUE(ModelsIdentical(LoadModel(Path("tvbu.json")), model, T));
}

TEST_F(ModelFileTest, RoundTripConstantSequenceKeepsHorizon) {
  TestRng rng(6);
  const ModelStep s = RandomStep(rng, 2, 1, 0);
  const Model model(std::vector<ModelStep>(3, s), Eigen::VectorXd::Zero(2), Eigen::MatrixXd::Identity(2, 2));
  SaveModel(Path("c.json"), model);
  const Model back = LoadModel(Path("c.json"));
  EXPECT_TRUE(ModelsIdentical(back, model, 3));
}

TEST_F(ModelFileTest, SavesCallbackModelsOverGivenSteps) {
  const Model::StepFunction f = [](int k) {
    return MakeStep(Eigen::MatrixXd::Constant(1, 1, 1.0 / k), Eigen::MatrixXd::Ones(1, 1),
                    Eigen::MatrixXd::Constant(1, 1, 0.1 * k), Eigen::MatrixXd::Ones(1, 1));
  };
  const Model unbounded(1, 1, f, Eigen::VectorXd::Zero(1), Eigen::MatrixXd::Ones(1, 1));
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { SaveModel(Path("f.json"), unbounded); },
                                         Path("f.json") + ": SaveModelOptions::steps"));
  SaveModelOptions options;
  options.steps = 4;
  SaveModel(Path("f.json"), unbounded, options);
  const Model back = LoadModel(Path("f.json"));
  EXPECT_EQ(back.horizon(), 4);
  for (int k = 1; k <= 4; ++k) {
    EXPECT_TRUE(SameBits(back.step(k)->A, f(k).A));
    EXPECT_TRUE(SameBits(back.step(k)->Q, f(k).Q));
  }
  const Model bounded(1, 1, f, Eigen::VectorXd::Zero(1), Eigen::MatrixXd::Ones(1, 1), 3);
  SaveModel(Path("g.json"), bounded);
  EXPECT_EQ(LoadModel(Path("g.json")).horizon(), 3);
  options.steps = 0;
  EXPECT_THROW(SaveModel(Path("h.json"), bounded, options), Error);
}

TEST_F(ModelFileTest, SaveRejectsMixedNoiseInputs) {
  TestRng rng(7);
  std::vector<ModelStep> steps;  // (braces evaluated in order)
  steps.push_back(RandomStep(rng, 2, 1, 1));
  steps.push_back(RandomStep(rng, 2, 1, 0));
  const Model model(steps, Eigen::VectorXd::Zero(2), Eigen::MatrixXd::Identity(2, 2));
  EXPECT_THROW(SaveModel(Path("mixed.json"), model), Error);
  EXPECT_THROW(SaveModel(Path("no/such/dir/m.json"),
                         Model(RandomStep(rng, 2, 1, 0), Eigen::VectorXd::Zero(2), Eigen::MatrixXd::Identity(2, 2))),
               Error);
}

// ----- Error paths: each names the file and the field ------------------------------------------

TEST_F(ModelFileTest, FileAndJsonErrors) {
  ExpectLoadErrorAt(Path("missing.json"), {"cannot open"});
  ExpectLoadError("", {"empty file"});
  ExpectLoadError("{\n  \"A\": [[1, 2],\n  oops\n}", {"invalid JSON", "line 3"});
  ExpectLoadError("[1, 2]", {"expected a JSON object"});
  ExpectLoadError(R"({"format": "numpy", )" + kCvFields + "}", {"field 'format'", "kfx-model"});
  ExpectLoadError(R"({"version": 2, )" + kCvFields + "}", {"field 'version'", "unsupported version 2"});
  ExpectLoadError(R"({"name": 3, )" + kCvFields + "}", {"field 'name'"});
}

TEST_F(ModelFileTest, MissingFields) {
  ExpectLoadError(R"({"C": [[1]], "Q": 1, "R": 1, "m0": 0, "P0": 1})", {"missing field 'A'"});
  ExpectLoadError(R"({"A": 1, "Q": 1, "R": 1, "m0": 0, "P0": 1})", {"missing field 'C'"});
  ExpectLoadError(R"({"A": 1, "C": 1, "Q": 1, "m0": 0, "P0": 1})", {"missing field 'R'"});
  ExpectLoadError(R"({"A": 1, "C": 1, "R": 1, "m0": 0, "P0": 1})", {"missing field 'Q'"});
  ExpectLoadError(R"({"A": 1, "C": 1, "Q": 1, "R": 1, "P0": 1})", {"missing field 'm0'"});
  ExpectLoadError(R"({"A": 1, "C": 1, "Q": 1, "R": 1, "m0": 0})", {"missing field 'P0'"});
  ExpectLoadError(R"({"A": 1, "C": 1, "B": 1, "R": 1, "m0": 0, "P0": 1})", {"field 'U'", "required with field 'B'"});
  ExpectLoadError(R"({"A": 1, "C": 1, "U": 1, "R": 1, "m0": 0, "P0": 1})", {"field 'B'", "required with field 'U'"});
}

TEST_F(ModelFileTest, ShapeErrors) {
  const std::string tail = R"("R": 1, "m0": [0, 0], "P0": [[1, 0], [0, 1]])";
  ExpectLoadError(R"({"A": [[1, 1], [0, 1]], "C": [[1, 0]], "Q": [[1, 0], [0, 1], [0, 0]], )" + tail + "}",
                  {"field 'Q': expected a 2x2 matrix, got 3x2"});
  ExpectLoadError(R"({"A": [[1, 1, 0], [0, 1, 0]], "C": [[1, 0]], "Q": 1, )" + tail + "}",
                  {"field 'A': expected a square matrix, got 2x3"});
  ExpectLoadError(R"({"A": [[1, 1], [0, 1]], "C": [[1, 0, 0]], "Q": [[1, 0], [0, 1]], )" + tail + "}",
                  {"field 'C': expected a matrix with 2 columns", "got 1x3"});
  ExpectLoadError(R"({"A": [[1, 1], [0, 1]], "C": [[1, 0]], "Q": [[1, 0], [0, 1]], "R": [[1, 0], [0, 1]],
      "m0": [0, 0], "P0": [[1, 0], [0, 1]]})",
                  {"field 'R': expected a 1x1 matrix, got 2x2"});
  ExpectLoadError(R"({"A": [[1, 1], [0, 1]], "C": [[1, 0]], "Q": [[1, 0], [0, 1]], "R": 1, "m0": [0, 0, 0],
      "P0": [[1, 0], [0, 1]]})",
                  {"field 'm0': expected a vector of length 2", "got length 3"});
  ExpectLoadError(R"({"A": [[1, 1], [0, 1]], "C": [[1, 0]], "Q": [[1, 0], [0, 1]], "R": 1, "m0": [0, 0], "P0": 1})",
                  {"field 'P0': expected a 2x2 matrix, got 1x1"});
  ExpectLoadError(R"({"A": [[1, 1], [0, 1]], "C": [[1, 0]], "B": [[1]], "U": 1, )" + tail + "}",
                  {"field 'B': expected a matrix with 2 rows"});
  ExpectLoadError(R"({"A": [[1, 1], [0, 1]], "C": [[1, 0]], "B": [[1], [0]], "U": [[1, 0], [0, 1]], )" + tail + "}",
                  {"field 'U': expected a 1x1 matrix, got 2x2"});
}

TEST_F(ModelFileTest, ValueErrors) {
  const std::string tail = R"("C": [[1, 0]], "R": 1, "m0": [0, 0], "P0": [[1, 0], [0, 1]])";
  ExpectLoadError(R"({"A": [[1, "x"], [0, 1]], "Q": [[1, 0], [0, 1]], )" + tail + "}",
                  {"field 'A': expected a number in row 1, column 2", "string"});
  ExpectLoadError(R"({"A": [[1, 1], [0, null]], "Q": [[1, 0], [0, 1]], )" + tail + "}",
                  {"field 'A': expected a number in row 2, column 2", "null"});
  ExpectLoadError(R"({"A": [[1, 1], [0]], "Q": [[1, 0], [0, 1]], )" + tail + "}",
                  {"field 'A': row 2 has 1 entries, expected 2"});
  ExpectLoadError(R"({"A": [[1, 1], 0], "Q": [[1, 0], [0, 1]], )" + tail + "}",
                  {"field 'A': expected a list of numbers in row 2"});
  ExpectLoadError(R"({"A": [1, 0], "Q": [[1, 0], [0, 1]], )" + tail + "}", {"field 'A'", "flat list"});
  ExpectLoadError(R"({"A": "eye", "Q": [[1, 0], [0, 1]], )" + tail + "}", {"field 'A'", "string"});
  ExpectLoadError(R"({"A": {"file": "A.npy"}, "Q": [[1, 0], [0, 1]], )" + tail + "}", {"field 'A'", "{\"npy\""});
  ExpectLoadError(R"({"A": [[[[1]]]], "Q": [[1, 0], [0, 1]], )" + tail + "}", {"field 'A'", "nested 4 deep"});
  ExpectLoadError(R"({"A": [[1, 1], [0, 1]], "Q": [[1, 0], [0, 1]], "C": [[1, 0]], "R": 1, "m0": ["a", 0],
      "P0": [[1, 0], [0, 1]]})",
                  {"field 'm0': expected a number in entry 1"});
  ExpectLoadError(R"({"A": [[1, 1], [0, 1]], "Q": [[1, 0], [0, 1]], "C": [[1, 0]], "R": 1, "m0": [0, 0],
      "P0": [[[1, 0], [0, 1]]]})",
                  {"field 'P0'", "cannot be time-varying"});
}

TEST_F(ModelFileTest, ModelValidationErrorsNameFileAndMatrix) {
  const std::string tail = R"("C": [[1, 0]], "R": 1, "m0": [0, 0], "P0": [[1, 0], [0, 1]])";
  ExpectLoadError(R"({"A": [[1, 1], [0, 1]], "Q": [[1, 0], [0, -1]], )" + tail + "}",
                  {"field 'Q': expected a positive semidefinite"});
  ExpectLoadError(R"({"A": [[1, 1], [0, 1]], "Q": [[1, 0.5], [0, 1]], )" + tail + "}",
                  {"field 'Q': expected a symmetric"});
  ExpectLoadError(R"({"A": [[1, 1], [0, 1]], "Q": [[1, 0], [0, 1]], "C": [[1, 0]], "R": 0, "m0": [0, 0],
      "P0": [[1, 0], [0, 1]]})",
                  {"field 'R': expected a positive definite"});
  // JSON has no NaN and the parser rejects an overflowing literal; a NaN in a .npy file is rejected
  // by the Model's validation.
  ExpectLoadError(R"({"A": [[1e999, 1], [0, 1]], "Q": [[1, 0], [0, 1]], )" + tail + "}", {"invalid JSON", "1e999"});
  Eigen::MatrixXd a = Eigen::MatrixXd::Identity(2, 2);
  a(0, 1) = std::nan("");
  WriteNpyMatrix(Path("A.npy"), a);
  ExpectLoadError(R"({"A": {"npy": "A.npy"}, "Q": [[1, 0], [0, 1]], )" + tail + "}",
                  {"field 'A': expected finite entries"});
  // In a time-varying model the step is named.
  ExpectLoadError(
      R"({"A": [[[1, 0], [0, 1]], [[1, 0], [0, 1]]], "Q": [[[1, 0], [0, 1]], [[1, 0], [0, -1]]], )" + tail + "}",
      {"field 'Q': step 2: expected a positive semidefinite"});
  ExpectLoadError(R"({"A": 1, "C": 1, "B": [[1e308]], "U": 1e308, "R": 1, "m0": 0, "P0": 1})",
                  {"field 'Q': expected finite"});
}

TEST_F(ModelFileTest, NpyReferenceErrors) {
  const std::string tail = R"("C": [[1, 0]], "Q": [[1, 0], [0, 1]], "R": 1, "m0": [0, 0], "P0": [[1, 0], [0, 1]])";
  ExpectLoadError(R"({"A": {"npy": "nope.npy"}, )" + tail + "}", {"field 'A'", "nope.npy", "cannot open"});
  WriteNpyVector(Path("v.npy"), Eigen::Vector2d(1, 2));
  ExpectLoadError(R"({"A": {"npy": "v.npy"}, )" + tail + "}", {"field 'A'", "expected a 2-D array", "(2,)"});
  std::vector<double> d(8, 0.0);
  WriteNpy(Path("t.npy"), {2, 2, 2}, d.data());
  ExpectLoadError(R"({"A": [[1, 1], [0, 1]], "C": [[1, 0]], "Q": [[1, 0], [0, 1]], "R": 1, "m0": {"npy": "t.npy"},
      "P0": [[1, 0], [0, 1]]})",
                  {"field 'm0'", "expected a vector"});
  ExpectLoadError(R"({"A": [[1, 1], [0, 1]], "C": [[1, 0]], "Q": [[1, 0], [0, 1]], "R": 1, "m0": [0, 0],
      "P0": {"npy": "t.npy"}})",
                  {"field 'P0'", "expected a 2-D array,"});
  WriteNpy(Path("e.npy"), {0, 2, 2}, nullptr);
  ExpectLoadError(R"({"A": {"npy": "e.npy"}, )" + tail + "}", {"field 'A'", "1 <= T"});
  std::ofstream(Path("junk.npy")) << "junk";
  ExpectLoadError(R"({"A": {"npy": "junk.npy"}, )" + tail + "}", {"field 'A'", "junk.npy", "not a .npy file"});
}

TEST_F(ModelFileTest, TimeVaryingAndHorizonErrors) {
  ExpectLoadError(R"({"A": [[[1]], [[1]], [[1]]], "C": 1, "Q": [[[1]], [[1]]], "R": 1, "m0": 0, "P0": 1})",
                  {"field 'Q': expected 3 steps (as field 'A'), got 2"});
  ExpectLoadError(R"({"A": [[[1]], [[1]]], "C": 1, "Q": 1, "R": 1, "m0": 0, "P0": 1, "horizon": 3})",
                  {"field 'horizon': expected 2", "got 3"});
  ExpectLoadError(R"({"A": [[[1]], [[1, 0]]], "C": 1, "Q": 1, "R": 1, "m0": 0, "P0": 1})",
                  {"field 'A': step 2: expected a 1x1 matrix (as step 1), got 1x2"});
  ExpectLoadError(R"({"A": [[[1]], [[1]]], "C": 1, "Q": 1, "R": [[[1]], [[1]], [[1]]], "m0": 0, "P0": 1})",
                  {"field 'R': expected 2 steps"});
  for (const char* h : {"0", "-1", "2.5", "\"10\"", "1e12", "3000000000"}) {
    ExpectLoadError(std::string(R"({"A": 1, "C": 1, "Q": 1, "R": 1, "m0": 0, "P0": 1, "horizon": )") + h + "}",
                    {"field 'horizon': expected a positive integer"});
  }
  // A huge horizon in a tiny file is refused before allocating.
  ExpectLoadError(R"({"A": [[1, 1], [0, 1]], "C": [[1, 0]], "Q": [[1, 0], [0, 1]], "R": 1, "m0": [0, 0],
      "P0": [[1, 0], [0, 1]], "horizon": 2000000000})",
                  {"field 'horizon'", "too large to hold in memory"});
}

// ----- The bundled examples -----------------------------------------------------------------

const std::string kModels = std::string(KFX_SOURCE_DIR) + "/examples/models/";

TEST(ModelFileExamplesTest, ConstantVelocity) {
  const Model model = LoadModel(kModels + "constant_velocity.json");
  ASSERT_EQ(model.state_dim(), 2);
  ASSERT_EQ(model.meas_dim(), 1);
  EXPECT_TRUE(model.time_invariant());
  const double dt = 1.0, q = 0.1;
  Eigen::MatrixXd A(2, 2), Q(2, 2), C(1, 2);
  A << 1, dt, 0, 1;
  Q << dt * dt * dt / 3, dt * dt / 2, dt * dt / 2, dt;
  Q *= q;
  C << 1, 0;
  const StepPtr s = model.step(1);
  EXPECT_MATRICES_NEAR(s->A, A, 0.0);
  EXPECT_MATRICES_NEAR(s->C, C, 0.0);
  EXPECT_MATRICES_NEAR(s->Q, Q, 1e-17);
  EXPECT_MATRICES_NEAR(s->R, Eigen::MatrixXd::Ones(1, 1), 0.0);
  EXPECT_MATRICES_NEAR(model.m0(), Eigen::Vector2d::Zero(), 0.0);
  EXPECT_MATRICES_NEAR(model.P0(), 10.0 * Eigen::MatrixXd::Identity(2, 2), 0.0);
}

TEST(ModelFileExamplesTest, DoubleIntegrator) {
  const Model model = LoadModel(kModels + "double_integrator.json");
  ASSERT_EQ(model.state_dim(), 2);
  ASSERT_EQ(model.meas_dim(), 1);
  const StepPtr s = model.step(1);
  const double dt = 0.1;
  Eigen::MatrixXd B(2, 1);
  B << dt * dt / 2, dt;
  EXPECT_MATRICES_NEAR(s->B, B, 1e-17);
  EXPECT_MATRICES_NEAR(s->Q, B * s->U * B.transpose(), 1e-17);
  EXPECT_EQ(s->A(0, 1), dt);
}

TEST(ModelFileExamplesTest, MassSpringChainMatchesAnIndependentDiscretization) {
  const Model model = LoadModel(kModels + "mass_spring_chain.json");
  ASSERT_EQ(model.state_dim(), 8);
  ASSERT_EQ(model.meas_dim(), 2);
  const StepPtr s = model.step(1);
  ASSERT_EQ(s->B.rows(), 8);
  ASSERT_EQ(s->B.cols(), 4);
  // The parameters stated in the file's description.
  const int N = 4;
  const double mass = 1.0, k = 1.0, c = 0.1, dt = 0.1;
  Eigen::MatrixXd T = Eigen::MatrixXd::Zero(N, N);
  for (int i = 0; i < N; ++i) {
    T(i, i) = i < N - 1 ? 2.0 : 1.0;
    if (i > 0) T(i, i - 1) = T(i - 1, i) = -1.0;
  }
  Eigen::MatrixXd aug = Eigen::MatrixXd::Zero(3 * N, 3 * N);  // [[Ac, Bc], [0, 0]]
  aug.block(0, N, N, N).setIdentity();
  aug.block(N, 0, N, N) = -k / mass * T;
  aug.block(N, N, N, N) = -c / mass * T;
  aug.block(N, 2 * N, N, N) = Eigen::MatrixXd::Identity(N, N) / mass;
  const Eigen::MatrixXd E = (aug * dt).exp();  // Pade approximant (Eigen), vs Taylor in the generator
  EXPECT_MATRICES_NEAR(s->A, E.topLeftCorner(2 * N, 2 * N), 1e-14);
  EXPECT_MATRICES_NEAR(s->B, E.topRightCorner(2 * N, N), 1e-15);
  EXPECT_MATRICES_NEAR(s->U, 0.01 * Eigen::MatrixXd::Identity(N, N), 0.0);
  EXPECT_MATRICES_NEAR(s->R, 0.0025 * Eigen::MatrixXd::Identity(2, 2), 0.0);
  EXPECT_EQ(s->C(0, 0), 1.0);
  EXPECT_EQ(s->C(1, N - 1), 1.0);
  EXPECT_EQ(s->C.sum(), 2.0);
  // Stable: spectral radius below one (lightly damped).
  const double rho = kfx::SpectralRadius(s->A);
  EXPECT_LT(rho, 1.0);
  EXPECT_GT(rho, 0.99);
}

// The ```json blocks of docs/formats.md, in order.
std::vector<std::string> DocJsonBlocks() {
  std::ifstream in(std::string(KFX_SOURCE_DIR) + "/docs/formats.md");
  std::vector<std::string> blocks;
  std::string line, block;
  bool inside = false;
  while (std::getline(in, line)) {
    if (!inside && line == "```json") {
      inside = true;
      block.clear();
    } else if (inside && line == "```") {
      inside = false;
      blocks.push_back(block);
    } else if (inside) {
      block += line + "\n";
    }
  }
  return blocks;
}

TEST(ModelFileExamplesTest, DocsWorkedExamplesLoad) {
  const std::vector<std::string> blocks = DocJsonBlocks();
  ASSERT_EQ(blocks.size(), 5u);
  // 1: the constant-velocity file, verbatim.
  std::ifstream in(kModels + "constant_velocity.json");
  EXPECT_EQ(blocks[0], std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()));
  // 3: the time-varying variant with a 3-D .npy.
  const fs::path dir = fs::temp_directory_path() / ("kfx_model_docs_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  std::vector<double> a_seq;
  for (int k = 0; k < 3; ++k) a_seq.insert(a_seq.end(), {1.0, 1.0, 0.0, 1.0});
  WriteNpy((dir / "cv.A.npy").string(), {3, 2, 2}, a_seq.data());
  std::ofstream((dir / "cv.json").string()) << blocks[2];
  const Model tv = LoadModel((dir / "cv.json").string());
  EXPECT_EQ(tv.horizon(), 3);
  EXPECT_EQ(tv.step(3)->R(0, 0), 4.0);
  EXPECT_TRUE(SameBits(tv.step(2)->Q, LoadModel(kModels + "constant_velocity.json").step(1)->Q));
  // 4: the fields of the driven cart (a fragment: its known input and cross-covariance), the same numbers as
  // examples/models/driven_cart.json.
  std::string fragment = blocks[3];
  fragment.erase(fragment.find_last_of(','));
  const nlohmann::json fields = nlohmann::json::parse("{" + fragment + "}");
  const Model cart_model = LoadModel(kModels + "driven_cart.json");
  const ModelStep& cart = *cart_model.step(1);
  for (const auto& [name, M] : {std::pair<std::string, const Eigen::MatrixXd*>{"Q", &cart.Q},
                                {"R", &cart.R},
                                {"G", &cart.G},
                                {"D", &cart.D},
                                {"S", &cart.S}}) {
    const auto& rows = fields.at(name);
    ASSERT_EQ(static_cast<Eigen::Index>(rows.size()), M->rows()) << name;
    for (Eigen::Index i = 0; i < M->rows(); ++i) {
      ASSERT_EQ(static_cast<Eigen::Index>(rows[i].size()), M->cols()) << name;
      for (Eigen::Index j = 0; j < M->cols(); ++j) EXPECT_EQ(rows[i][j].get<double>(), (*M)(i, j)) << name;
    }
  }
  // 5: the continuous-time model file, the same model as examples/continuous/oscillator.json.
  std::ofstream((dir / "osc.json").string()) << blocks[4];
  const ContinuousModelFile doc = LoadContinuousModel((dir / "osc.json").string());
  const ContinuousModelFile file = LoadContinuousModel(kModels + "../continuous/oscillator.json");
  EXPECT_EQ(doc.dt, file.dt);
  for (const auto& [a, b] : {std::pair{&doc.model.A, &file.model.A},
                             {&doc.model.Q, &file.model.Q},
                             {&doc.model.C, &file.model.C},
                             {&doc.model.R, &file.model.R},
                             {&doc.model.P0, &file.model.P0}}) {
    EXPECT_TRUE(SameBits(*a, *b));
  }
  fs::remove_all(dir);
}

TEST(ModelFileExamplesTest, ExamplesRoundTrip) {
  const fs::path dir = fs::temp_directory_path() / ("kfx_model_examples_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  for (const char* name : {"constant_velocity", "double_integrator", "mass_spring_chain"}) {
    const Model model = LoadModel(kModels + name + ".json");
    const std::string path = (dir / (std::string(name) + ".json")).string();
    SaveModel(path, model);
    EXPECT_TRUE(ModelsIdentical(LoadModel(path), model, 1)) << name;
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace kfx
