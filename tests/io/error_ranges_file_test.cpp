// Tests of src/io/error_ranges_file.cpp: LoadErrorRanges on the bundled examples and on hand-written
// files; every error names the file (and the field where there is one).
#include "kfx/error_ranges_file.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "kfx/error.hpp"
#include "kfx/io.hpp"
#include "support/expect_error.hpp"
#include "support/file_testing.hpp"
#include "support/matrix_testing.hpp"

namespace kfx {
namespace {

using Eigen::MatrixXd;

const std::string kExamples = std::string(KFX_SOURCE_DIR) + "/examples/";

class ErrorRangesFileTest : public testing::TempDirTest {
 protected:
  void SetUp() override {
    TempDirTest::SetUp();
    design_ = *LoadModel(kExamples + "models/patel_toda.json").step(1);  // n = 2, m = 1, noise input p = 1
  }
  // Loads `json` and expects a kfx::Error starting with the file's path and containing every text.
  void ExpectError(const std::string& json, const std::vector<std::string>& texts) const {
    ExpectErrorAt(Write("ranges.json", json), texts);
  }
  void ExpectErrorAt(const std::string& path, const std::vector<std::string>& texts) const {
    EXPECT_TRUE(testing::ThrowsErrorStartingWith([&] { LoadErrorRanges(path, design_); }, path + ": ", texts));
  }

  ModelStep design_;
};

TEST_F(ErrorRangesFileTest, LoadsTheBundledExamples) {
  const ErrorRanges plant = LoadErrorRanges(kExamples + "ranges/patel_toda_ranges.json", design_);
  EXPECT_MATRICES_NEAR(plant.A, (MatrixXd(2, 2) << 0.1, 0.0, 0.0, 0.0).finished(), 0.0);
  EXPECT_EQ(plant.C.size(), 0);
  EXPECT_EQ(plant.Q.size(), 0);
  EXPECT_EQ(plant.R.size(), 0);
  const ErrorRanges noise = LoadErrorRanges(kExamples + "ranges/patel_toda_noise_ranges.json", design_);
  EXPECT_EQ(noise.A.size(), 0);
  EXPECT_MATRICES_NEAR(noise.Q, MatrixXd::Constant(1, 1, 1.0), 0.0);
  EXPECT_MATRICES_NEAR(noise.R, MatrixXd::Constant(1, 1, 0.5), 0.0);
}

TEST_F(ErrorRangesFileTest, FileAndHeaderErrors) {
  ExpectErrorAt(Path("missing.json"), {"cannot open"});
  ExpectError("[1]", {"expected a JSON object"});
  ExpectError("{\"A\": [[1, 0]", {"invalid JSON"});
  ExpectError(R"({"format": "kfx-model", "R": 1})", {"field 'format'", "kfx-error-ranges"});
  ExpectError(R"({"version": 2, "R": 1})", {"field 'version'"});
  ExpectError(R"({"format": "kfx-error-ranges"})", {"expected at least one of the fields"});
}

TEST_F(ErrorRangesFileTest, ValidationErrorsNameTheFileAndTheMatrix) {
  ExpectError(R"({"A": [[-0.1, 0], [0, 0]]})", {"ranges.A"});
  ExpectError(R"({"R": [[0.5, 0]]})", {"ranges.R"});
  ExpectError(R"({"Q": [[0.5, 0], [0.1, 0]]})", {"ranges.Q"});
}

}  // namespace
}  // namespace kfx
