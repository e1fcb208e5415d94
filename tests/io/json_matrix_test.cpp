// Tests of src/io/json_matrix.cpp, the one set of rules for matrices and vectors written inline in kfx's
// JSON files (docs/formats.md, "Matrices and vectors in JSON files"): first the rules on JSON values,
// one test per class of bad input, then the same bad inputs through each of the three readers that use
// them (model file, error-ranges file, coupled model file), which must give the same message.
#include "io/json_matrix.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "kfx/coupled_model_file.hpp"
#include "kfx/error.hpp"
#include "kfx/error_ranges_file.hpp"
#include "kfx/io.hpp"
#include "support/expect_error.hpp"
#include "support/file_testing.hpp"
#include "support/matrix_testing.hpp"

namespace kfx {
namespace {

using detail::Json;
using detail::JsonField;
using Eigen::MatrixXd;
using Eigen::VectorXd;

const JsonField kField{"m.json", "Q", ""};

// Runs `f` and expects a kfx::Error whose message contains every text.
void ExpectError(const std::function<void()>& f, const std::vector<std::string>& texts) {
  EXPECT_TRUE(testing::ThrowsErrorStartingWith(f, "", texts));
}
void ExpectMatrixError(const std::string& json, const std::string& text) {
  ExpectError([&] { detail::JsonMatrix(Json::parse(json), kField); }, {"m.json: field 'Q': " + text});
}
void ExpectVectorError(const std::string& json, const std::string& text) {
  ExpectError([&] { detail::JsonVector(Json::parse(json), kField); }, {"m.json: field 'Q': " + text});
}

// ----- The rules on JSON values ---------------------------------------------------------------------

TEST(JsonMatrixRules, AcceptedForms) {
  EXPECT_MATRICES_NEAR(detail::JsonMatrix(Json::parse("2.5"), kField), MatrixXd::Constant(1, 1, 2.5), 0.0);
  EXPECT_MATRICES_NEAR(detail::JsonMatrix(Json::parse("[[1, 2], [3, -4e-3]]"), kField),
                       (MatrixXd(2, 2) << 1, 2, 3, -4e-3).finished(), 0.0);
  EXPECT_MATRICES_NEAR(detail::JsonMatrix(Json::parse("[[1, 2, 3]]"), kField), (MatrixXd(1, 3) << 1, 2, 3).finished(),
                       0.0);
  EXPECT_MATRICES_NEAR(detail::JsonMatrix(Json::parse("[[1], [2]]"), kField, 2, 1), (MatrixXd(2, 1) << 1, 2).finished(),
                       0.0);
  // Vectors: a number, a list of numbers, or a column.
  EXPECT_MATRICES_NEAR(detail::JsonVector(Json::parse("7"), kField), VectorXd::Constant(1, 7.0), 0.0);
  EXPECT_MATRICES_NEAR(detail::JsonVector(Json::parse("[1, 2, 3]"), kField), Eigen::Vector3d(1, 2, 3), 0.0);
  EXPECT_MATRICES_NEAR(detail::JsonVector(Json::parse("[[1], [2]]"), kField), Eigen::Vector2d(1, 2), 0.0);
  // The largest integers and doubles are numbers like any other.
  EXPECT_EQ(detail::JsonMatrix(Json::parse("[[1.7976931348623157e308]]"), kField)(0, 0),
            std::numeric_limits<double>::max());
}

TEST(JsonMatrixRules, EmptyListsOnlyWhereTheShapeIsEmpty) {
  ExpectMatrixError("[]", "expected a matrix as a list of rows (e.g. [[1, 0]]), got an empty list");
  ExpectMatrixError("[[]]", "expected at least one number in row 1, got an empty list");
  ExpectMatrixError("[[1, 0], []]", "expected at least one number in row 2, got an empty list");
  ExpectVectorError("[]", "expected a vector as a list of numbers, got an empty list");
  // [] is the matrix with no entries where the format fixes such a shape (a coupled model's U for r = 0).
  EXPECT_EQ(detail::JsonMatrix(Json::parse("[]"), kField, 0, 0).size(), 0);
  EXPECT_EQ(detail::JsonMatrix(Json::parse("[]"), kField, 3, 0).rows(), 3);
  ExpectError([] { detail::JsonMatrix(Json::parse("[[]]"), kField, 1, 0); }, {"row 1, got an empty list"});
  ExpectError([] { detail::JsonMatrix(Json::parse("[]"), kField, 2, 2); }, {"got an empty list"});
}

TEST(JsonMatrixRules, WrongNesting) {
  ExpectMatrixError("[1, 0]", "expected a matrix as a list of rows (e.g. [[1, 0]] for one row), got a flat list");
  ExpectMatrixError("[[[1]]]", "expected a matrix (a list of rows), got lists nested 3 deep");
  ExpectMatrixError("[[[[1, 0]]]]", "expected a matrix (a list of rows), got lists nested 4 deep");
  ExpectMatrixError("[[[[[[[[[[[[1]]]]]]]]]]]]",
                    "expected a matrix (a list of rows), got lists nested 9 deep");  // 9 at most
  ExpectMatrixError("[[1, 0], [[0], 1]]", "expected a number in row 2, column 1, got array [0]");
  ExpectVectorError("[[[1]], [[2]]]", "expected a vector as a list of numbers, got lists nested 3 deep");
  ExpectVectorError("[[1, 2]]", "expected a vector (a list of numbers, or a column [[1], [2]]), got a 1x2 matrix");
  ExpectVectorError("[1, [2]]", "expected a number in entry 2, got array [2]");
}

TEST(JsonMatrixRules, RaggedRows) {
  ExpectMatrixError("[[1, 0], [0]]", "row 2 has 1 entries, expected 2 (as row 1)");
  ExpectMatrixError("[[1], [0, 1], [2]]", "row 2 has 2 entries, expected 1 (as row 1)");
  ExpectVectorError("[[1], [2, 3]]", "row 2 has 2 entries, expected 1 (as row 1)");
}

TEST(JsonMatrixRules, NonNumbers) {
  ExpectMatrixError(R"([[1, "x"], [0, 1]])", "expected a number in row 1, column 2, got string \"x\"");
  ExpectMatrixError("[[1, 0], [0, null]]", "expected a number in row 2, column 2, got null");
  ExpectMatrixError("[[true]]", "expected a number in row 1, column 1, got boolean true");
  ExpectMatrixError("[[1, 0], 0]", "expected a list of numbers in row 2, got number 0");
  ExpectMatrixError(R"("eye")", "expected a matrix as a list of rows, got string \"eye\"");
  ExpectMatrixError("null", "expected a matrix as a list of rows, got null");
  ExpectMatrixError(R"({"npy": "Q.npy"})", "expected a matrix as a list of rows, got object");
  ExpectVectorError(R"(["a", 0])", "expected a number in entry 1, got string \"a\"");
  ExpectVectorError("false", "expected a vector as a list of numbers, got boolean false");
}

TEST(JsonMatrixRules, NonFiniteNumbers) {
  // JSON text cannot hold NaN or infinity (and 1e999 is a parse error: see the readers below), but a
  // JSON value built in memory can.
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  ExpectError(
      [&] {
        detail::JsonMatrix(Json::array({Json::array({1.0, nan})}), kField);
      },
      {"m.json: field 'Q': expected a finite number in row 1, column 2, got nan"});
  ExpectError([&] { detail::JsonMatrix(Json(-inf), kField); },
              {"m.json: field 'Q': expected a finite number, got -inf"});
  ExpectError(
      [&] {
        detail::JsonVector(Json::array({0.0, inf}), kField);
      },
      {"m.json: field 'Q': expected a finite number in entry 2, got inf"});
  ExpectError([&] { detail::JsonVector(Json::array({Json::array({nan})}), kField); },
              {"expected a finite number in row 1, column 1, got nan"});
}

TEST(JsonMatrixRules, WrongShape) {
  ExpectError([] { detail::JsonMatrix(Json::parse("[[1, 0, 0], [0, 1, 0]]"), kField, 2, 2); },
              {"m.json: field 'Q': expected a 2x2 matrix, got 2x3"});
  ExpectError([] { detail::JsonMatrix(Json::parse("3"), kField, 2, 2); }, {"expected a 2x2 matrix, got 1x1"});
  ExpectError([] { detail::JsonMatrix(Json::parse("[[3]]"), kField, 0, 0); }, {"expected a 0x0 matrix, got 1x1"});
}

TEST(JsonMatrixRules, MessagesCarryTheContext) {
  ExpectError(
      [] {
        detail::JsonMatrix(Json::parse("[[1], [0, 1]]"), JsonField{"m.json", "A", "step 3: "});
      },
      {"m.json: field 'A': step 3: row 2 has 2 entries"});
}

// ----- The file and its header ------------------------------------------------------------------------

using JsonFileTest = testing::TempDirTest;

TEST_F(JsonFileTest, ReadJsonObjectNamesTheFile) {
  const std::string format = "kfx-test";
  const auto read = [&](const std::string& path) { return [path, format] { detail::ReadJsonObject(path, format); }; };
  ExpectError(read(dir_.string()), {dir_.string() + ": is a directory"});
  ExpectError(read(Path("missing.json")), {"missing.json: cannot open file for reading"});
  ExpectError(read(Write("empty.json", " \n\t")), {"empty.json: empty file, expected a JSON object"});
  ExpectError(read(Write("bad.json", "{\n\"a\": \n}")), {"bad.json: invalid JSON: parse error at line 3"});
  ExpectError(read(Write("list.json", "[1]")),
              {"list.json: expected a JSON object {\"format\": \"kfx-test\", ...}, got array [1]"});
  EXPECT_EQ(detail::ReadJsonObject(Write("ok.json", R"({"a": 1})"), format)["a"], 1);
}

TEST_F(JsonFileTest, FormatVersionAndIntegerFields) {
  const Json j = Json::parse(R"({"format": "kfx-other", "version": 2, "n": 3, "r": -1, "x": 2.5})");
  ExpectError([&] { detail::CheckJsonFormat(j, "f.json", "kfx-test", false); },
              {"f.json: field 'format': expected \"kfx-test\", got string \"kfx-other\""});
  ExpectError([] { detail::CheckJsonFormat(Json::object(), "f.json", "kfx-test", true); },
              {"f.json: missing field 'format'"});
  detail::CheckJsonFormat(Json::object(), "f.json", "kfx-test", false);
  ExpectError([&] { detail::CheckJsonVersion(j, "f.json", 1); },
              {"f.json: field 'version': unsupported version 2 (this kfx reads version 1)"});
  detail::CheckJsonVersion(Json::parse(R"({"version": 1.0})"), "f.json", 1);
  EXPECT_EQ(detail::JsonIndex(j, "f.json", "n", 1), 3);
  ExpectError([&] { detail::JsonIndex(j, "f.json", "r", 0); },
              {"f.json: field 'r': expected an integer >= 0, got number -1"});
  ExpectError([&] { detail::JsonIndex(j, "f.json", "x", 0); }, {"field 'x': expected an integer >= 0, got number 2.5"});
  ExpectError([&] { detail::JsonIndex(j, "f.json", "d", 1); }, {"f.json: missing field 'd'"});
}

TEST(JsonNpyReference, RelativeToTheJsonFile) {
  const JsonField f{"dir/sub/m.json", "A", ""};
  EXPECT_EQ(detail::JsonNpyReference(Json::parse(R"({"npy": "A.npy"})"), f), "dir/sub/A.npy");
  EXPECT_EQ(detail::JsonNpyReference(Json::parse(R"({"npy": "/abs/A.npy"})"), f), "/abs/A.npy");
  ExpectError([&] { detail::JsonNpyReference(Json::parse(R"({"file": "A.npy"})"), f); },
              {"dir/sub/m.json: field 'A': expected {\"npy\": \"file.npy\"}, got object"});
  ExpectError([&] { detail::JsonNpyReference(Json::parse(R"({"npy": "A.npy", "x": 1})"), f); }, {"field 'A'"});
}

// ----- The same rules in the three readers ----------------------------------------------------------

// One valid file of each format with a 2 x 2 matrix field set to the JSON text under test: P0 of a model
// file, Q of an error-ranges file (for a design with a full Q), P0 of a coupled model file (c = 2).
class ReadersTest : public testing::TempDirTest {
 protected:
  struct Reader {
    std::string name;   // the reader, for failure messages
    std::string field;  // the field that holds the value
    std::function<void(const std::string& value)> read;
  };

  std::vector<Reader> Readers() {
    const ModelStep design = MakeStep((MatrixXd(2, 2) << 1, 1, 0, 1).finished(), (MatrixXd(1, 2) << 1, 0).finished(),
                                      MatrixXd::Identity(2, 2), MatrixXd::Ones(1, 1));
    return {
        {"LoadModel", "P0",
         [this](const std::string& v) {
           LoadModel(Write("model.json", R"({"A": [[1, 1], [0, 1]], "C": [[1, 0]], "Q": [[1, 0], [0, 1]], "R": 1,
               "m0": [0, 0], "P0": )" + v + "}"));
         }},
        {"LoadErrorRanges", "Q",
         [this, design](const std::string& v) {
           LoadErrorRanges(Write("ranges.json", R"({"Q": )" + v + "}"), design);
         }},
        {"LoadCoupledModelSlice", "P0",
         [this](const std::string& v) {
           LoadCoupledModelSlice(Write("coupled.json", R"({"format": "kfx-coupled-model", "n": 3, "c": 2, "d": 1,
               "r": 1, "F": [[0.9, 0], [0, 0.9]], "H": [[1, 0]], "V": [[0.1, 0], [0, 0.1]], "R": 0.5, "G": [[1], [0]],
               "U": [[0.2]], "P0": )" + v + "}"),
                                 0, 3);
         }},
    };
  }

  // Every reader fails on `value` with "<its file>: field '<its field>': ..." containing `text`.
  void ExpectSameError(const std::string& value, const std::string& text) {
    for (const Reader& r : Readers()) {
      SCOPED_TRACE(r.name + " on " + value);
      EXPECT_TRUE(testing::ThrowsErrorStartingWith([&] { r.read(value); }, (dir_ / "").string(),
                                                   {".json: field '" + r.field + "': ", text}));
    }
  }
};

TEST_F(ReadersTest, AllReadTheSameMatrix) {
  for (const Reader& r : Readers()) {
    SCOPED_TRACE(r.name);
    EXPECT_NO_THROW(r.read("[[0.5, 0], [0, 0.5]]"));
  }
}

TEST_F(ReadersTest, WrongNesting) {
  ExpectSameError("[1, 0]", "expected a matrix as a list of rows (e.g. [[1, 0]] for one row), got a flat list");
  ExpectSameError("[[[[1, 0]]]]", "got lists nested 4 deep");
  ExpectSameError("[]", "got an empty list");
  ExpectSameError("[[]]", "expected at least one number in row 1, got an empty list");
}

TEST_F(ReadersTest, RaggedRows) { ExpectSameError("[[1, 0], [0]]", "row 2 has 1 entries, expected 2 (as row 1)"); }

TEST_F(ReadersTest, NonNumbers) {
  ExpectSameError(R"([[1, "x"], [0, 1]])", "expected a number in row 1, column 2, got string \"x\"");
  ExpectSameError("[[1, 0], [0, false]]", "expected a number in row 2, column 2, got boolean false");
  ExpectSameError("[[1, 0], 0]", "expected a list of numbers in row 2, got number 0");
}

TEST_F(ReadersTest, NonFiniteNumbers) {
  // Out of the range of double in JSON text: a JSON error, naming the file.
  for (const Reader& r : Readers()) {
    SCOPED_TRACE(r.name);
    ExpectError([&] { r.read("[[1e999, 0], [0, 1]]"); }, {".json: invalid JSON", "1e999"});
  }
}

TEST_F(ReadersTest, WrongShape) {
  // The same text; the error-ranges file names the matrix as its validation does ("ranges.Q").
  for (const Reader& r : Readers()) {
    SCOPED_TRACE(r.name);
    ExpectError([&] { r.read("[[1, 0, 0], [0, 1, 0]]"); }, {(r.name == "LoadErrorRanges" ? "ranges.Q" : "field 'P0'") +
                                                            std::string(": expected a 2x2 matrix, got 2x3")});
  }
}

}  // namespace
}  // namespace kfx
