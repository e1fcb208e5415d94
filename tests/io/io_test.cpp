// Tests of src/io/csv.cpp: CSV time series and ReadTimeSeries / WriteTimeSeries (format by extension).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <vector>

#include <sys/stat.h>
#include <unistd.h>

#include "kfx/error.hpp"
#include "kfx/io.hpp"
#include "support/expect_error.hpp"
#include "support/matrix_testing.hpp"

namespace kfx {
namespace {

namespace fs = std::filesystem;

bool SameBits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

class IoTestBase : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() /
           ("kfx_io_test_" + std::to_string(::getpid()) + "_" + info->test_suite_name() + "_" + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }
  std::string Write(const std::string& name, const std::string& text) const {
    const std::string path = Path(name);
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out << text;
    return path;
  }
  static std::string Read(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  // Expects ReadTimeSeries to throw a kfx::Error whose message holds the path and every one of `texts`.
  static void ExpectReadError(const std::string& path, const std::vector<std::string>& texts) {
    EXPECT_TRUE(testing::ThrowsErrorNaming([&] { ReadTimeSeries(path); }, path, texts));
  }

  fs::path dir_;
};

using CsvTest = IoTestBase;
using TimeSeriesIoTest = IoTestBase;

TEST_F(CsvTest, ReadsHeaderAndValues) {
  const std::string path = Write("y.csv", "y1, y2 ,\"y 3\"\n1,2,3\n-4.5, 5e-3 ,+6\n");
  std::vector<std::string> names;
  const TimeSeries y = ReadTimeSeries(path, &names);
  EXPECT_EQ(names, (std::vector<std::string>{"y1", "y2", "y 3"}));
  ASSERT_EQ(y.rows(), 2);
  ASSERT_EQ(y.cols(), 3);
  EXPECT_EQ(y(0, 0), 1.0);
  EXPECT_EQ(y(1, 0), -4.5);
  EXPECT_EQ(y(1, 1), 0.005);
  EXPECT_EQ(y(1, 2), 6.0);
}

TEST_F(CsvTest, ReadsWithoutHeader) {
  std::vector<std::string> names = {"stale"};
  const TimeSeries y = ReadTimeSeries(Write("y.csv", "0.5\n1.5\n2.5"), &names);  // no final newline
  EXPECT_TRUE(names.empty());
  ASSERT_EQ(y.rows(), 3);
  ASSERT_EQ(y.cols(), 1);
  EXPECT_EQ(y(2, 0), 2.5);
}

TEST_F(CsvTest, SkipsCommentsAndBlankLinesAndHandlesCrlfAndBom) {
  const std::string text = "\xEF\xBB\xBF# measurements\r\n\r\n  # indented comment\r\nt,y\r\n1,2\r\n# c\r\n3,4\r\n\r\n";
  std::vector<std::string> names;
  const TimeSeries y = ReadTimeSeries(Write("y.csv", text), &names);
  EXPECT_EQ(names, (std::vector<std::string>{"t", "y"}));
  ASSERT_EQ(y.rows(), 2);
  EXPECT_EQ(y(1, 1), 4.0);
}

TEST_F(CsvTest, MissingValuesReadAsNaN) {
  const TimeSeries y = ReadTimeSeries(Write("y.csv", "a,b,c\nnan,NaN,NAN\n,1,\n-nan, ,inf\n"));
  ASSERT_EQ(y.rows(), 3);
  for (int j = 0; j < 3; ++j) EXPECT_TRUE(std::isnan(y(0, j))) << j;
  EXPECT_TRUE(std::isnan(y(1, 0)));
  EXPECT_EQ(y(1, 1), 1.0);
  EXPECT_TRUE(std::isnan(y(1, 2)));
  EXPECT_TRUE(std::isnan(y(2, 0)));
  EXPECT_TRUE(std::isnan(y(2, 1)));
  EXPECT_EQ(y(2, 2), std::numeric_limits<double>::infinity());
  // A first line of missing values is data, not a header.
  const TimeSeries z = ReadTimeSeries(Write("z.csv", "nan,\n1,2\n"));
  EXPECT_EQ(z.rows(), 2);
  // A header may have an empty name (pandas writes one for the index column).
  std::vector<std::string> names;
  const TimeSeries w = ReadTimeSeries(Write("w.csv", ",y\n0,1.5\n"), &names);
  EXPECT_EQ(names, (std::vector<std::string>{"", "y"}));
  EXPECT_EQ(w(0, 1), 1.5);
}

// Issue 20, class 7: the CSV rules for every dialect that used to be read as something else (each case
// was accepted before: 0 steps, a dropped first row, a dropped blank row).
TEST_F(CsvTest, HeaderOnlyIsAnErrorNotZeroRows) {
  ExpectReadError(Write("y.csv", "a,b\n"), {"no data rows"});
  ExpectReadError(Write("y2.csv", "a,b\n# nothing else\n\n"), {"no data rows"});
}

TEST_F(CsvTest, CrOnlyLineEndingsAreLines) {
  const TimeSeries y = ReadTimeSeries(Write("cr.csv", "t,y\r1,2\r3,4\r"));
  ASSERT_EQ(y.rows(), 2);
  EXPECT_EQ(y(1, 1), 4.0);
  const TimeSeries z = ReadTimeSeries(Write("cr1.csv", "1\r2\r3"));  // one column, no header, no final CR
  ASSERT_EQ(z.rows(), 3);
  EXPECT_EQ(z(2, 0), 3.0);
  const TimeSeries w = ReadTimeSeries(Write("mixed.csv", "1\r\n2\r3\n4\n"));
  ASSERT_EQ(w.rows(), 4);
  EXPECT_EQ(w(3, 0), 4.0);
}

TEST_F(CsvTest, NumericLookingFirstLineIsDataNotAHeader) {
  for (const std::string first : {"1e999", "0x10", "-1e999", "inf", "+.5e", "Infinity", "-nan(x)"}) {
    const std::string path = Write("h.csv", first + "\n1\n2\n");
    EXPECT_TRUE(testing::ThrowsErrorNaming([&] { ReadTimeSeries(path); }, path, {"line 1, column 1"}) ||
                ReadTimeSeries(path).rows() == 3)
        << first;  // either parsed as a value (inf) or an error naming its place, never dropped
  }
  EXPECT_EQ(ReadTimeSeries(Write("inf.csv", "inf\n1\n")).rows(), 2);
  ExpectReadError(Write("x.csv", "0x10,a\n1,2\n"), {"line 1, column 1", "'0x10'"});
  ExpectReadError(Write("e.csv", "1e999\n1\n"), {"line 1, column 1", "'1e999'"});
}

TEST_F(CsvTest, BlankLineInOneColumnIsAMissingValueInItsRow) {
  const TimeSeries y = ReadTimeSeries(Write("y.csv", "y\n1\n\n3\n  \n5\n\n\n"));
  ASSERT_EQ(y.rows(), 5);  // trailing blank lines end the file; inner ones are rows
  EXPECT_EQ(y(0, 0), 1.0);
  EXPECT_TRUE(std::isnan(y(1, 0)));
  EXPECT_EQ(y(2, 0), 3.0);
  EXPECT_TRUE(std::isnan(y(3, 0)));
  EXPECT_EQ(y(4, 0), 5.0);
  // With two columns a blank line is a row of the wrong length, named.
  ExpectReadError(Write("two.csv", "1,2\n\n3,4\n"), {"line 2", "expected 2 fields", "got 1"});
}

TEST_F(CsvTest, OtherSeparatorsAreErrorsNamingLineAndColumn) {
  ExpectReadError(Write("semi.csv", "1;2;3\n4;5;6\n"), {"line 1, column 1", "'1;2;3'", "separated by ','"});
  ExpectReadError(Write("semih.csv", "a;b\n1;2\n"), {"line 1, column 1", "'a;b'", "separated by ','"});
  ExpectReadError(Write("tab.csv", "a\tb\n1\t2\n"), {"line 1, column 1", "separated by ','"});
  ExpectReadError(Write("few.csv", "a,b,c\n1,2,3\n4,5\n"), {"line 3, column 3", "expected 3 fields", "got 2"});
  ExpectReadError(Write("many.csv", "1,2\n3,4,5\n"), {"line 2, column 3", "expected 2 fields", "got 3"});
}

TEST_F(CsvTest, RaggedRowsNameFileAndLine) {
  ExpectReadError(Write("r.csv", "a,b,c\n1,2,3\n# comment\n4,5\n"), {"line 4", "expected 3 fields", "got 2"});
  ExpectReadError(Write("r2.csv", "1,2\n3,4,5\n"), {"line 2", "expected 2 fields (as line 1)", "got 3"});
}

TEST_F(CsvTest, NonNumericFieldsNameLineAndColumn) {
  ExpectReadError(Write("n.csv", "a,b\n1,2\n3,x4\n"), {"line 3, column 2", "expected a number", "'x4'"});
  // Text mixed with numbers on the first line is a bad data line, not a header.
  ExpectReadError(Write("m.csv", "1,abc\n2,3\n"), {"line 1, column 2", "'abc'"});
  // A second header-like line is data.
  ExpectReadError(Write("h.csv", "a,b\nc,d\n"), {"line 2, column 1", "'c'"});
  // Locale-style decimal commas are not numbers.
  ExpectReadError(Write("d.csv", "t;y\n1;5\n"), {"line 1, column 1", "'t;y'"});
  // Out of the range of double.
  ExpectReadError(Write("o.csv", "1\n1e999\n"), {"line 2, column 1", "'1e999'"});
  ExpectReadError(Write("p.csv", "1\n0x10\n"), {"line 2", "'0x10'"});
}

TEST_F(CsvTest, EmptyAndMissingFilesAreErrors) {
  ExpectReadError(Write("e.csv", ""), {"empty file"});
  ExpectReadError(Write("c.csv", "# only a comment\n\n"), {"no data"});
  ExpectReadError(Path("missing.csv"), {"cannot open"});
  fs::create_directories(Path("dir.csv"));
  ExpectReadError(Path("dir.csv"), {"is a directory"});
}

TEST_F(CsvTest, RoundTripIsBitwiseIncludingNaN) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  TimeSeries y(4, 3);
  y << 0.1, -0.0, 5e-324,                                                                      //
      1.7976931348623157e308, -1.0 / 3.0, nan,                                                 //
      2.2250738585072014e-308, std::numeric_limits<double>::infinity(), 123456789012345680.0,  //
      1e-7, 100.0, -2.5;
  WriteTimeSeries(Path("y.csv"), y, {"a", "b", "c"});
  std::vector<std::string> names;
  const TimeSeries back = ReadTimeSeries(Path("y.csv"), &names);
  EXPECT_EQ(names, (std::vector<std::string>{"a", "b", "c"}));
  ASSERT_EQ(back.rows(), 4);
  ASSERT_EQ(back.cols(), 3);
  for (Eigen::Index i = 0; i < 4; ++i) {
    for (Eigen::Index j = 0; j < 3; ++j) {
      if (std::isnan(y(i, j))) {
        EXPECT_TRUE(std::isnan(back(i, j)));
      } else {
        EXPECT_TRUE(SameBits(back(i, j), y(i, j))) << i << "," << j << ": " << back(i, j) << " vs " << y(i, j);
      }
    }
  }
  EXPECT_EQ(Read(Path("y.csv")).substr(0, 20), "a,b,c\n0.1,-0,5e-324\n");
  // Random values without a header.
  kfx::testing::TestRng rng(3);
  const TimeSeries r = rng.Gaussian(50, 4) * 1e3;
  WriteTimeSeries(Path("r.csv"), r);
  EXPECT_MATRICES_NEAR(ReadTimeSeries(Path("r.csv")), r, 0.0);
}

TEST_F(CsvTest, WriteRejectsBadColumnNames) {
  const TimeSeries y = TimeSeries::Zero(2, 2);
  EXPECT_THROW(WriteTimeSeries(Path("y.csv"), y, {"a"}), Error);
  EXPECT_THROW(WriteTimeSeries(Path("y.csv"), y, {"a", "b,c"}), Error);
  EXPECT_THROW(WriteTimeSeries(Path("y.csv"), y, {"a", "\"b\""}), Error);
  EXPECT_THROW(WriteTimeSeries(Path("y.csv"), y, {"a", "1"}), Error);
  EXPECT_THROW(WriteTimeSeries(Path("y.csv"), y, {"a", "nan"}), Error);
  EXPECT_THROW(WriteTimeSeries(Path("y.csv"), y, {"a", ""}), Error);
  EXPECT_THROW(WriteTimeSeries(Path("y.csv"), y, {"#a", "b"}), Error);
  EXPECT_THROW(WriteTimeSeries(Path("y.csv"), TimeSeries(0, 2)), Error);  // nothing to read back
  EXPECT_THROW(WriteTimeSeries(Path("y.csv"), TimeSeries(3, 0)), Error);
  EXPECT_TRUE(
      testing::ThrowsErrorNaming([&] { WriteTimeSeries(Path("no/such/dir/y.csv"), y); }, Path("no/such/dir/y.csv")));
  // No rows, even with a header: it would not read back (a CSV series has at least one row, issue 20).
  EXPECT_THROW(WriteTimeSeries(Path("h.csv"), TimeSeries(0, 2), {"a", "b"}), Error);
}

TEST_F(TimeSeriesIoTest, NpyTimeSeriesShapes) {
  kfx::testing::TestRng rng(11);
  const TimeSeries y = rng.Gaussian(6, 2);
  WriteTimeSeries(Path("y.npy"), y, {"ignored", "names"});
  const NpyArray raw = ReadNpy(Path("y.npy"));
  EXPECT_EQ(raw.shape, (std::vector<std::int64_t>{6, 2}));
  EXPECT_EQ(raw.data[1], y(0, 1));  // time-major: row 0 is the first measurement
  EXPECT_MATRICES_NEAR(ReadTimeSeries(Path("y.npy")), y, 0.0);
  // (T,) reads as T x 1.
  const Eigen::VectorXd v = Eigen::VectorXd::LinSpaced(5, 0.0, 1.0);
  WriteNpyVector(Path("v.npy"), v);
  const TimeSeries tv = ReadTimeSeries(Path("v.npy"));
  EXPECT_EQ(tv.cols(), 1);
  EXPECT_MATRICES_NEAR(tv, v, 0.0);
  // Other ranks are rejected.
  const double s = 1.0;
  WriteNpy(Path("s.npy"), {}, &s);
  ExpectReadError(Path("s.npy"), {"expected a time series of shape (T, m) or (T,), got shape ()"});
  std::vector<double> d(8, 0.0);
  WriteNpy(Path("c.npy"), {2, 2, 2}, d.data());
  ExpectReadError(Path("c.npy"), {"got shape (2, 2, 2)"});
  EXPECT_THROW(WriteTimeSeries(Path("y2.npy"), y, {"one"}), Error);
}

TEST_F(TimeSeriesIoTest, NpyAndCsvGiveTheSameSeries) {
  const std::string dir = std::string(KFX_TEST_DATA_DIR) + "/npy/";
  const TimeSeries from_npy = ReadTimeSeries(dir + "f8_2x3.npy");
  WriteTimeSeries(Path("a.csv"), from_npy);
  const TimeSeries from_csv = ReadTimeSeries(Path("a.csv"));
  ASSERT_EQ(from_csv.rows(), 2);
  for (Eigen::Index i = 0; i < 2; ++i)
    for (Eigen::Index j = 0; j < 3; ++j) EXPECT_TRUE(SameBits(from_csv(i, j), from_npy(i, j)));
}

TEST_F(TimeSeriesIoTest, FormatIsChosenByExtension) {
  const TimeSeries y = TimeSeries::Ones(2, 2);
  WriteTimeSeries(Path("upper.CSV"), y);
  EXPECT_EQ(Read(Path("upper.CSV")), "1,1\n1,1\n");
  EXPECT_MATRICES_NEAR(ReadTimeSeries(Path("upper.CSV")), y, 0.0);
  for (const char* name : {"y.txt", "y", "y.npz", "y.csv.gz"}) {
    EXPECT_TRUE(
        testing::ThrowsErrorNaming([&] { WriteTimeSeries(Path(name), y); }, Path(name), {"expected .npy or .csv"}))
        << name;
    ExpectReadError(Write(name, "1\n"), {"unknown time-series file extension"});
  }
  // A CSV file named .npy is not a .npy file.
  ExpectReadError(Write("wrong.npy", "1,2\n"), {"not a .npy file"});
}

using AtomicOutputTest = IoTestBase;

// Outputs go to a temporary name and are renamed on success (issue 11): a failed or abandoned write
// leaves the previous file untouched and no temporary file behind.
TEST_F(AtomicOutputTest, AbandonedWriteLeavesOldFileAndNoTemporary) {
  const std::string path = Write("y.csv", "old\n");
  {
    AtomicOutputFile file(path);
    file.stream() << "half-written";
    EXPECT_TRUE(fs::exists(file.temp_path()));
    EXPECT_EQ(Read(path), "old\n");  // not visible under the final name before Commit()
  }
  EXPECT_EQ(Read(path), "old\n");
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()), 1);
}

TEST_F(AtomicOutputTest, CommitReplacesAndWritersLeaveNoTemporary) {
  const std::string path = Write("y.csv", "old\n");
  WriteTimeSeries(path, TimeSeries::Ones(2, 1));
  EXPECT_EQ(Read(path), "1\n1\n");
  WriteTimeSeries(Path("y.npy"), TimeSeries::Ones(2, 1));
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()), 2);
}

TEST_F(AtomicOutputTest, FailedRenameIsAnErrorAndLeavesNoTemporary) {
  fs::create_directories(dir_ / "x.npy" / "inside");  // a non-empty directory where the file should go
  EXPECT_TRUE(
      testing::ThrowsErrorNaming([&] { WriteTimeSeries(Path("x.npy"), TimeSeries::Ones(2, 1)); }, Path("x.npy")));
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_), fs::directory_iterator()), 1);
  EXPECT_THROW({ AtomicOutputFile f(Path("no-such-dir/y.csv")); }, Error);
}

// Issue 20, class 5: a directory of outputs is one complete run (its marker, written last) or visibly
// incomplete. Before OutputDirectory, a run that failed between its files left the previous summary.json.
TEST_F(AtomicOutputTest, OutputDirectoryRemovesTheOldMarkerFirstAndWritesItLast) {
  const std::string out = Path("out");
  {
    OutputDirectory d(out, "summary.json");
    WriteTimeSeries(d.Path("a.npy"), TimeSeries::Ones(2, 1));
    d.Commit("{\"run\": 1}");
  }
  EXPECT_EQ(Read(Path("out/summary.json")), "{\"run\": 1}\n");
  // A second run that fails after its first file: the first run's marker is gone (visibly incomplete).
  try {
    OutputDirectory d(out, "summary.json");
    EXPECT_FALSE(fs::exists(Path("out/summary.json")));
    WriteTimeSeries(d.Path("a.npy"), TimeSeries::Zero(3, 1));
    WriteTimeSeries(d.Path("b.npy/"), TimeSeries::Zero(3, 1));  // fails: not a file name
    d.Commit("{\"run\": 2}");
    ADD_FAILURE() << "expected the write of b.npy/ to fail";
  } catch (const Error&) {
  }
  EXPECT_FALSE(fs::exists(Path("out/summary.json")));
  // A non-owner (an MPI rank other than 0) leaves the marker to the owner.
  { OutputDirectory(out, "summary.json").Commit("{\"run\": 3}"); }
  OutputDirectory other(out, "summary.json", /*owner=*/false);
  EXPECT_TRUE(fs::exists(Path("out/summary.json")));
  EXPECT_THROW(other.Commit("{}"), Error);
  // A marker name that is a directory, a directory that cannot be made: errors naming them.
  fs::create_directories(Path("odd/summary.json/x"));
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { OutputDirectory(Path("odd"), "summary.json"); }, Path("odd")));
  Write("file", "x");
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { OutputDirectory(Path("file/sub"), "summary.json"); }, "-o/--out"));
}

// Issue 20, class 11: a FIFO (or another non-regular file) given as a CSV, .npy, model, coupled model or
// error-range file is a clean error; before, the open blocked forever waiting for a writer.
TEST_F(TimeSeriesIoTest, FifosAndOtherNonRegularFilesAreRejectedWithoutBlocking) {
  for (const std::string name : {"y.csv", "y.npy", "m.json"}) {
    ASSERT_EQ(::mkfifo(Path(name).c_str(), 0600), 0) << name;
  }
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { ReadTimeSeries(Path("y.csv")); }, Path("y.csv"), {"FIFO"}));
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { ReadTimeSeries(Path("y.npy")); }, Path("y.npy"), {"FIFO"}));
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { ReadNpy(Path("y.npy")); }, Path("y.npy"), {"FIFO"}));
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { ReadNpySlice(Path("y.npy"), 0, 0, 1); }, Path("y.npy"), {"FIFO"}));
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { LoadModel(Path("m.json")); }, Path("m.json"), {"FIFO"}));
  // A model file whose matrix is a FIFO .npy.
  const std::string model = Write("model.json",
                                  R"({"format": "kfx-model", "version": 1, "A": {"npy": "y.npy"}, "C": [[1]],
                                      "Q": [[1]], "R": [[1]], "m0": [0], "P0": [[1]]})");
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { LoadModel(model); }, "y.npy", {"FIFO"}));
  fs::create_symlink("/dev/null", Path("null.csv"));  // a character device behind a .csv name
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { ReadTimeSeries(Path("null.csv")); }, Path("null.csv"), {"device"}));
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { ReadNpy("/dev/zero"); }, "/dev/zero", {"device"}));
}

}  // namespace
}  // namespace kfx
