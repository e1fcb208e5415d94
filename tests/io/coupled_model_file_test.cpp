// Tests of src/io/coupled_model_file.cpp: the coupled model file's own rules (the header fields, inline
// fields repeated for every subsystem, m0 as a vector, U = [] for r = 0, per-subsystem .npy fields);
// every error names the file and the field. The matrix rules shared with the other readers are tested
// in json_matrix_test.cpp, slices against SliceCoupledSystem in tests/distributed/distributed_test.cpp.
#include "kfx/coupled_model_file.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include "kfx/error.hpp"
#include "kfx/io.hpp"
#include "support/expect_error.hpp"
#include "support/file_testing.hpp"
#include "support/matrix_testing.hpp"

namespace kfx {
namespace {

using Eigen::MatrixXd;
using Eigen::VectorXd;

// n = 3 subsystems of c = 2 states, d = 1 measurement, r = 1 coupling input; every field inline but P0.
const std::string kHead = R"("format": "kfx-coupled-model", "n": 3, "c": 2, "d": 1, "r": 1)";
const std::string kFields = R"("F": [[0.9, 0.1], [0, 0.9]], "H": [[1, 0]], "V": [[0.1, 0], [0, 0.1]], "R": 0.5,
  "G": [[1], [0]], "U": [[0.2]])";

class CoupledModelFileTest : public testing::TempDirTest {
 protected:
  std::string Write(const std::string& body) const { return TempDirTest::Write("coupled.json", "{" + body + "}"); }
  // Loads subsystems [0, 3) of {body} and expects an error starting with the file's path, containing texts.
  void ExpectError(const std::string& body, const std::vector<std::string>& texts) const {
    const std::string path = Write(body);
    EXPECT_TRUE(testing::ThrowsErrorStartingWith([&] { LoadCoupledModelSlice(path, 0, 3); }, path + ": ", texts));
  }
};

TEST_F(CoupledModelFileTest, InlineFieldsAreRepeatedForEverySubsystem) {
  const std::string path = Write(kHead + ", " + kFields + R"(, "m0": [1, 2], "P0": [[2, 0], [0, 3]])");
  const CoupledModelHeader h = ReadCoupledModelHeader(path);
  EXPECT_EQ(h.n, 3);
  EXPECT_EQ(h.c, 2);
  EXPECT_MATRICES_NEAR(h.U, MatrixXd::Constant(1, 1, 0.2), 0.0);
  const CoupledSystem s = LoadCoupledModelSlice(path, 1, 2);
  EXPECT_EQ(s.n(), 2);
  const MatrixXd F = (MatrixXd(2, 2) << 0.9, 0.1, 0, 0.9).finished();
  EXPECT_MATRICES_NEAR(s.step(1)->F, F.replicate(1, 2), 0.0);
  EXPECT_MATRICES_NEAR(s.step(1)->G, (MatrixXd(4, 1) << 1, 0, 1, 0).finished(), 0.0);
  EXPECT_MATRICES_NEAR(s.m0(), (VectorXd(4) << 1, 2, 1, 2).finished(), 0.0);
  EXPECT_MATRICES_NEAR(s.P0_blocks(), (MatrixXd(2, 4) << 2, 0, 2, 0, 0, 3, 0, 3).finished(), 0.0);
}

TEST_F(CoupledModelFileTest, M0IsAVectorAndOptional) {
  const std::string tail = kHead + ", " + kFields + R"(, "P0": [[1, 0], [0, 1]])";
  EXPECT_MATRICES_NEAR(LoadCoupledModelSlice(Write(tail + R"(, "m0": [[1], [2]])"), 0, 1).m0(), Eigen::Vector2d(1, 2),
                       0.0);
  EXPECT_MATRICES_NEAR(LoadCoupledModelSlice(Write(tail), 0, 3).m0(), VectorXd::Zero(6), 0.0);
  ExpectError(tail + R"(, "m0": [1, 2, 3])", {"field 'm0': expected a vector of length 2, got length 3"});
  ExpectError(tail + R"(, "m0": [[1, 2]])", {"field 'm0': expected a vector", "got a 1x2 matrix"});
  ExpectError(tail + R"(, "m0": ["a", 0])", {"field 'm0': expected a number in entry 1"});
}

TEST_F(CoupledModelFileTest, AOneRowMatrixIsAListOfRows) {
  // H is d x c = 1 x 2: [[1, 0]]. The flat list [1, 0] is a vector, not a matrix (the reader before the
  // one set of rules took it).
  const std::string body = kHead + R"(, "F": [[0.9, 0.1], [0, 0.9]], "H": [1, 0], "V": [[0.1, 0], [0, 0.1]],
      "R": 0.5, "G": [[1], [0]], "U": [[0.2]], "P0": [[1, 0], [0, 1]])";
  ExpectError(body, {"field 'H': expected a matrix as a list of rows", "got a flat list"});
}

TEST_F(CoupledModelFileTest, HeaderErrors) {
  const std::string rest = ", " + kFields + R"(, "P0": [[1, 0], [0, 1]])";
  ExpectError(R"("n": 3, "c": 2, "d": 1, "r": 1)" + rest, {"missing field 'format'", "kfx-coupled-model"});
  ExpectError(R"("format": "kfx-model", "n": 3, "c": 2, "d": 1, "r": 1)" + rest,
              {"field 'format': expected \"kfx-coupled-model\", got string \"kfx-model\""});
  ExpectError(R"("format": "kfx-coupled-model", "n": 0, "c": 2, "d": 1, "r": 1)" + rest,
              {"field 'n': expected an integer >= 1, got number 0"});
  ExpectError(R"("format": "kfx-coupled-model", "n": 3, "c": 2.5, "d": 1, "r": 1)" + rest,
              {"field 'c': expected an integer >= 1, got number 2.5"});
  ExpectError(R"("format": "kfx-coupled-model", "n": 3, "c": 2, "r": 1)" + rest, {"missing field 'd'"});
  ExpectError(kHead + R"(, "F": 0.9, "H": [[1, 0]], "V": [[0.1, 0], [0, 0.1]], "R": 0.5, "G": [[1], [0]],
      "P0": [[1, 0], [0, 1]])",
              {"missing field 'U'"});
  ExpectError(kHead + R"(, "H": [[1, 0]], "V": [[0.1, 0], [0, 0.1]], "R": 0.5, "G": [[1], [0]], "U": [[0.2]],
      "P0": [[1, 0], [0, 1]])",
              {"missing field 'F'"});
  ExpectError(kHead + ", " + kFields, {"missing field 'P0'"});
}

TEST_F(CoupledModelFileTest, UIsEmptyWithoutACouplingInput) {
  const std::string path =
      Write(R"("format": "kfx-coupled-model", "n": 3, "c": 2, "d": 1, "r": 0, "U": [], "P0": [[1, 0], [0, 1]])");
  EXPECT_EQ(ReadCoupledModelHeader(path).U.size(), 0);
  Write(R"("format": "kfx-coupled-model", "n": 3, "c": 2, "d": 1, "r": 0, "U": [[]])");
  EXPECT_THROW(ReadCoupledModelHeader(path), Error);
  Write(R"("format": "kfx-coupled-model", "n": 3, "c": 2, "d": 1, "r": 1, "U": [])");
  EXPECT_THROW(ReadCoupledModelHeader(path), Error);
}

TEST_F(CoupledModelFileTest, NpyFieldErrorsNameTheFieldAndTheArray) {
  const std::string fields = R"(, "H": [[1, 0]], "V": [[0.1, 0], [0, 0.1]], "R": 0.5, "G": [[1], [0]],
      "U": [[0.2]], "P0": [[1, 0], [0, 1]])";
  ExpectError(kHead + R"(, "F": {"npy": "none.npy"})" + fields, {"field 'F': ", "none.npy", "cannot open"});
  std::vector<double> f(3 * 2 * 2, 0.5);
  f[5] = std::nan("");
  WriteNpy(Path("F.npy"), {3, 2, 2}, f.data());
  ExpectError(kHead + R"(, "F": {"npy": "F.npy"})" + fields, {"field 'F': ", "F.npy: expected finite entries"});
  WriteNpy(Path("F3.npy"), {3, 3, 2}, std::vector<double>(18, 0.5).data());
  ExpectError(kHead + R"(, "F": {"npy": "F3.npy"})" + fields, {"field 'F': expected an array of shape (3, 2, 2)"});
  ExpectError(kHead + R"(, "F": {"file": "F.npy"})" + fields, {"field 'F': expected {\"npy\": \"file.npy\"}"});
}

// Issue 20: a per-subsystem .npy field holds exactly n subsystems (before, only the slice read was checked:
// the first subsystems of a longer array, or a slice within a shorter one, were taken for the model's).
TEST_F(CoupledModelFileTest, NpyFieldsHoldExactlyTheModelsSubsystems) {
  const std::string fields = R"(, "H": [[1, 0]], "V": [[0.1, 0], [0, 0.1]], "R": 0.5, "G": [[1], [0]],
      "U": [[0.2]], "P0": [[1, 0], [0, 1]])";
  WriteNpy(Path("F4.npy"), {4, 2, 2}, std::vector<double>(16, 0.5).data());
  WriteNpy(Path("F2.npy"), {2, 2, 2}, std::vector<double>(8, 0.5).data());
  for (const std::string file : {"F4.npy", "F2.npy"}) {
    const std::string path = Write(kHead + R"(, "F": {"npy": ")" + file + "\"}" + fields);
    const std::vector<std::pair<int, int>> slices = {{0, 3}, {0, 1}, {1, 1}};
    for (const std::pair<int, int>& slice : slices) {
      EXPECT_TRUE(testing::ThrowsErrorStartingWith([&] { LoadCoupledModelSlice(path, slice.first, slice.second); },
                                                   path + ": ", {"field 'F': expected 3 subsystems", file}))
          << file << " slice " << slice.first << "+" << slice.second;
    }
  }
  WriteNpy(Path("F3.npy"), {3, 2, 2}, std::vector<double>(12, 0.5).data());
  EXPECT_EQ(LoadCoupledModelSlice(Write(kHead + R"(, "F": {"npy": "F3.npy"})" + fields), 1, 2).n(), 2);
}

}  // namespace
}  // namespace kfx
