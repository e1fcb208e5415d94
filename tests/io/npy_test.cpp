// Tests of src/io/npy.cpp: the .npy reader and writer.
// Oracles: fixtures written by numpy 1.24.2 (tests/data/npy/make_fixtures.py, values repeated here),
// byte-for-byte equality of our writer with numpy.save, round trips, and every malformed input.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <unistd.h>

#include "kfx/error.hpp"
#include "kfx/io.hpp"
#include "support/expect_error.hpp"
#include "support/matrix_testing.hpp"

namespace kfx {
namespace {

namespace fs = std::filesystem;

const std::string kData = std::string(KFX_TEST_DATA_DIR) + "/npy/";

std::string ReadBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void WriteBytes(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

std::string DoubleBytes(const std::vector<double>& values) {
  std::string s(values.size() * 8, '\0');
  std::memcpy(s.data(), values.data(), s.size());  // the test machine is little-endian (x86-64)
  return s;
}

// A .npy file around a hand-written header dict (padded to 64 bytes like numpy).
std::string MakeNpy(const std::string& dict, const std::string& data, int major = 1) {
  std::string header = dict;
  const std::size_t prefix = major == 1 ? 10 : 12;
  header.append(64 - (prefix + header.size() + 1) % 64, ' ');
  header += '\n';
  std::string out = "\x93NUMPY";
  out += static_cast<char>(major);
  out += '\0';
  const std::size_t len = header.size();
  out += static_cast<char>(len & 0xff);
  out += static_cast<char>((len >> 8) & 0xff);
  if (major != 1) out += std::string(2, '\0');
  return out + header + data;
}

// Bitwise comparison (distinguishes -0.0 from 0.0 and compares NaN payloads).
bool SameBits(double a, double b) { return std::memcmp(&a, &b, sizeof a) == 0; }

class NpyTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    dir_ = fs::temp_directory_path() / ("kfx_npy_test_" + std::to_string(::getpid()) + "_" + info->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }

  // Writes `bytes` to a file and expects ReadNpy to throw a kfx::Error mentioning the path and `text`.
  void ExpectReadError(const std::string& bytes, const std::string& text) {
    const std::string path = Path("bad.npy");
    WriteBytes(path, bytes);
    EXPECT_TRUE(testing::ThrowsErrorNaming([&] { ReadNpy(path); }, path, {text}));
  }

  fs::path dir_;
};

const std::vector<double> kA = {0.1, -2.5, 5e-324, 3.0, M_PI, -0.0};  // f8_2x3.npy, C order

TEST_F(NpyTest, ReadsNumpyFloat64Matrix) {
  const NpyArray a = ReadNpy(kData + "f8_2x3.npy");
  ASSERT_EQ(a.shape, (std::vector<std::int64_t>{2, 3}));
  ASSERT_EQ(a.data.size(), 6u);
  for (std::size_t i = 0; i < 6; ++i) EXPECT_TRUE(SameBits(a.data[i], kA[i])) << i;
  const Eigen::MatrixXd m = ReadNpyMatrix(kData + "f8_2x3.npy");
  ASSERT_EQ(m.rows(), 2);
  ASSERT_EQ(m.cols(), 3);
  EXPECT_EQ(m(0, 1), -2.5);
  EXPECT_EQ(m(1, 1), M_PI);
  EXPECT_TRUE(std::signbit(m(1, 2)));
}

TEST_F(NpyTest, ConvertsFortranOrderToCOrder) {
  EXPECT_EQ(ReadNpy(kData + "f8_2x3_fortran.npy").data, ReadNpy(kData + "f8_2x3.npy").data);
  const NpyArray c = ReadNpy(kData + "f8_2x3x4.npy");
  const NpyArray f = ReadNpy(kData + "f8_2x3x4_fortran.npy");
  ASSERT_EQ(f.shape, (std::vector<std::int64_t>{2, 3, 4}));
  EXPECT_EQ(f.data, c.data);
  // T[i, j, k] = (12 i + 4 j + k) / 2 - 3 (make_fixtures.py).
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 4; ++k) EXPECT_EQ(c.data[12 * i + 4 * j + k], (12 * i + 4 * j + k) * 0.5 - 3.0);
}

TEST_F(NpyTest, ReadsScalarVectorAndEmptyArrays) {
  const NpyArray s = ReadNpy(kData + "f8_scalar.npy");
  EXPECT_TRUE(s.shape.empty());
  EXPECT_EQ(s.data, std::vector<double>{2.75});
  const NpyArray v = ReadNpy(kData + "f8_vector5.npy");
  EXPECT_EQ(v.shape, std::vector<std::int64_t>{5});
  EXPECT_EQ(v.data, (std::vector<double>{1.5, -1.0, 0.0, 1e10, -3.25}));
  const NpyArray e = ReadNpy(kData + "f8_empty_0x3.npy");
  EXPECT_EQ(e.shape, (std::vector<std::int64_t>{0, 3}));
  EXPECT_TRUE(e.data.empty());
  // ReadNpyMatrix: 1-D of length n is n x 1; 0-D and 3-D are rejected.
  const Eigen::MatrixXd col = ReadNpyMatrix(kData + "f8_vector5.npy");
  EXPECT_EQ(col.rows(), 5);
  EXPECT_EQ(col.cols(), 1);
  EXPECT_EQ(col(3, 0), 1e10);
  EXPECT_EQ(ReadNpyMatrix(kData + "f8_empty_0x3.npy").cols(), 3);
  EXPECT_THROW(ReadNpyMatrix(kData + "f8_scalar.npy"), Error);
  EXPECT_THROW(ReadNpyMatrix(kData + "f8_2x3x4.npy"), Error);
}

TEST_F(NpyTest, ReadsOtherNumericDtypes) {
  EXPECT_EQ(ReadNpy(kData + "f4_vector.npy").data, (std::vector<double>{static_cast<double>(0.1f), -1.5, 3.0}));
  EXPECT_EQ(ReadNpy(kData + "i8_2x2.npy").data, (std::vector<double>{-1099511627776.0, -1.0, 0.0, 1099511627779.0}));
  EXPECT_EQ(ReadNpy(kData + "i4_vector.npy").data, (std::vector<double>{-7.0, 0.0, 2147483647.0, -2147483648.0}));
  EXPECT_EQ(ReadNpy(kData + "u1_vector.npy").data, (std::vector<double>{0.0, 1.0, 255.0}));
  EXPECT_EQ(ReadNpy(kData + "b1_2x2.npy").data, (std::vector<double>{1.0, 0.0, 0.0, 1.0}));
}

TEST_F(NpyTest, ReadsFormatVersions2And3) {
  const std::vector<double> expected = ReadNpy(kData + "f8_2x3.npy").data;
  for (const char* name : {"f8_2x3_v2.npy", "f8_2x3_v3.npy"}) {
    const NpyArray a = ReadNpy(kData + name);
    EXPECT_EQ(a.shape, (std::vector<std::int64_t>{2, 3})) << name;
    EXPECT_EQ(a.data, expected) << name;
  }
}

TEST_F(NpyTest, WriterProducesNumpyBytes) {
  Eigen::MatrixXd a(2, 3);
  a << kA[0], kA[1], kA[2], kA[3], kA[4], kA[5];
  WriteNpyMatrix(Path("a.npy"), a);
  EXPECT_EQ(ReadBytes(Path("a.npy")), ReadBytes(kData + "f8_2x3.npy"));

  Eigen::VectorXd v(5);
  v << 1.5, -1.0, 0.0, 1e10, -3.25;
  WriteNpyVector(Path("v.npy"), v);
  EXPECT_EQ(ReadBytes(Path("v.npy")), ReadBytes(kData + "f8_vector5.npy"));

  const double s = 2.75;
  WriteNpy(Path("s.npy"), {}, &s);
  EXPECT_EQ(ReadBytes(Path("s.npy")), ReadBytes(kData + "f8_scalar.npy"));

  std::vector<double> t(24);
  for (int i = 0; i < 24; ++i) t[i] = i * 0.5 - 3.0;
  WriteNpy(Path("t.npy"), {2, 3, 4}, t.data());
  EXPECT_EQ(ReadBytes(Path("t.npy")), ReadBytes(kData + "f8_2x3x4.npy"));

  WriteNpy(Path("e.npy"), {0, 3}, nullptr);
  EXPECT_EQ(ReadBytes(Path("e.npy")), ReadBytes(kData + "f8_empty_0x3.npy"));
}

TEST_F(NpyTest, WriterHeaderIsPaddedTo64BytesAndEndsWithNewline) {
  const std::vector<std::vector<std::int64_t>> shapes = {
      {}, {0}, {1}, {3, 5}, {1, 2, 1, 2, 1, 2, 1, 2, 1, 2, 1, 2, 1, 2, 1, 2}, std::vector<std::int64_t>(64, 1)};
  for (const auto& shape : shapes) {
    std::int64_t count = 1;
    for (auto d : shape) count *= d;
    std::vector<double> data(static_cast<std::size_t>(count), 1.0);
    WriteNpy(Path("h.npy"), shape, data.data());
    const std::string bytes = ReadBytes(Path("h.npy"));
    ASSERT_GE(bytes.size(), 10u);
    const std::size_t header_len = static_cast<unsigned char>(bytes[8]) + 256u * static_cast<unsigned char>(bytes[9]);
    EXPECT_EQ(bytes[6], '\x01');
    EXPECT_EQ(bytes[7], '\x00');
    EXPECT_EQ((10 + header_len) % 64, 0u);
    EXPECT_EQ(bytes[10 + header_len - 1], '\n');
    EXPECT_EQ(bytes.size(), 10 + header_len + 8 * data.size());
    EXPECT_EQ(ReadNpy(Path("h.npy")).shape, shape);
  }
}

TEST_F(NpyTest, RoundTripIsBitwise) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const std::vector<double> special = {
      0.0, -0.0, 5e-324, 2.2250738585072014e-308, 1.7976931348623157e308, 0.1, -1.0 / 3.0, nan, inf, -inf};
  const std::vector<std::vector<std::int64_t>> shapes = {{}, {0}, {1}, {10}, {2, 5}, {5, 2}, {1, 0, 2}, {2, 1, 5}};
  for (const auto& shape : shapes) {
    std::int64_t count = 1;
    for (auto d : shape) count *= d;
    std::vector<double> data(static_cast<std::size_t>(count));
    for (std::size_t i = 0; i < data.size(); ++i) data[i] = special[i % special.size()];
    WriteNpy(Path("r.npy"), shape, data.data());
    const NpyArray back = ReadNpy(Path("r.npy"));
    EXPECT_EQ(back.shape, shape);
    ASSERT_EQ(back.data.size(), data.size());
    for (std::size_t i = 0; i < data.size(); ++i) EXPECT_TRUE(SameBits(back.data[i], data[i])) << i;
  }
  kfx::testing::TestRng rng(7);
  const Eigen::MatrixXd m = rng.Gaussian(13, 7);
  WriteNpyMatrix(Path("m.npy"), m);
  EXPECT_MATRICES_NEAR(ReadNpyMatrix(Path("m.npy")), m, 0.0);
  // A strided (non-contiguous) block is written in its logical order.
  WriteNpyMatrix(Path("b.npy"), m.block(2, 1, 4, 3));
  EXPECT_MATRICES_NEAR(ReadNpyMatrix(Path("b.npy")), m.block(2, 1, 4, 3), 0.0);
}

TEST_F(NpyTest, ParsesHeaderDictVariants) {
  const std::string data = DoubleBytes({1, 2, 3, 4, 5, 6});
  const std::vector<std::string> dicts = {
      "{'descr': '<f8', 'fortran_order': False, 'shape': (2, 3), }",
      "{'shape': (2, 3), 'fortran_order': False, 'descr': '<f8'}",
      "{ 'fortran_order' : False ,'shape':(2,3,),'descr':'<f8' , }",
      "{\"descr\": \"<f8\", \"fortran_order\": False, \"shape\": (2L, 3L)}",
      "{'descr': '=f8', 'fortran_order': False, 'shape': (2, 3)}",
      "{'descr': 'f8', 'fortran_order': False, 'shape': (2, 3), 'extra': [1, (2,), None]}",
  };
  for (const std::string& dict : dicts) {
    for (int major : {1, 2, 3}) {
      WriteBytes(Path("h.npy"), MakeNpy(dict, data, major));
      const NpyArray a = ReadNpy(Path("h.npy"));
      EXPECT_EQ(a.shape, (std::vector<std::int64_t>{2, 3})) << dict;
      EXPECT_EQ(a.data, (std::vector<double>{1, 2, 3, 4, 5, 6})) << dict;
    }
  }
  // Shapes: scalar, one element, 1-D with and without spaces.
  WriteBytes(Path("s.npy"), MakeNpy("{'descr': '<f8', 'fortran_order': True, 'shape': ( ), }", DoubleBytes({4})));
  EXPECT_EQ(ReadNpy(Path("s.npy")).data, std::vector<double>{4});
  WriteBytes(Path("v.npy"),
             MakeNpy("{'descr': '<f8', 'fortran_order': True, 'shape': ( 3 , ), }", DoubleBytes({1, 2, 3})));
  EXPECT_EQ(ReadNpy(Path("v.npy")).data, (std::vector<double>{1, 2, 3}));
  // Small integer types: '<i2', '|i1', '<u2', '<u4', '<u8'.
  WriteBytes(Path("i2.npy"),
             MakeNpy("{'descr': '<i2', 'fortran_order': False, 'shape': (2,)}", std::string("\xff\xff\x02\x01", 4)));
  EXPECT_EQ(ReadNpy(Path("i2.npy")).data, (std::vector<double>{-1.0, 258.0}));
  WriteBytes(Path("i1.npy"),
             MakeNpy("{'descr': '|i1', 'fortran_order': False, 'shape': (2,)}", std::string("\x80\x7f", 2)));
  EXPECT_EQ(ReadNpy(Path("i1.npy")).data, (std::vector<double>{-128.0, 127.0}));
  WriteBytes(Path("u4.npy"),
             MakeNpy("{'descr': '<u4', 'fortran_order': False, 'shape': (1,)}", std::string("\xff\xff\xff\xff", 4)));
  EXPECT_EQ(ReadNpy(Path("u4.npy")).data, (std::vector<double>{4294967295.0}));
}

TEST_F(NpyTest, RejectsUnsupportedDtypesNamingFileAndDtype) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"f8_big_endian.npy", "'>f8' (big-endian"},
      {"c16_vector.npy", "'<c16' (complex)"},
      {"object.npy", "'|O' (object array)"},
      {"structured.npy", "structured array"},
  };
  for (const auto& [name, text] : cases) {
    const std::string file = name;  // C++17: a lambda cannot capture a structured binding (clang rejects it)
    EXPECT_TRUE(testing::ThrowsErrorNaming([&] { ReadNpy(kData + file); }, kData + file, {text})) << file;
  }
  const std::string data = DoubleBytes({1});
  ExpectReadError(MakeNpy("{'descr': '<f2', 'fortran_order': False, 'shape': (4,)}", data), "'<f2' (half precision)");
  ExpectReadError(MakeNpy("{'descr': '<f16', 'fortran_order': False, 'shape': (1,)}", data), "'<f16'");
  ExpectReadError(MakeNpy("{'descr': '<U1', 'fortran_order': False, 'shape': (2,)}", data), "'<U1' (string)");
  ExpectReadError(MakeNpy("{'descr': '<M8[ns]', 'fortran_order': False, 'shape': (1,)}", data), "'<M8[ns]'");
  ExpectReadError(MakeNpy("{'descr': '>i4', 'fortran_order': False, 'shape': (2,)}", data), "'>i4' (big-endian");
}

TEST_F(NpyTest, RejectsTruncatedAndTrailingData) {
  const std::string good = ReadBytes(kData + "f8_2x3.npy");
  ASSERT_EQ(good.size(), 128u + 48u);
  ExpectReadError(good.substr(0, good.size() - 5), "expected 48 bytes of data, got 43");
  ExpectReadError(good.substr(0, 128), "expected 48 bytes of data, got 0");
  ExpectReadError(good + "xyz", "expected 48 bytes of data, got 51");
  ExpectReadError(good.substr(0, 100), "truncated .npy header");
  ExpectReadError(good.substr(0, 9), "truncated .npy header");
  ExpectReadError(good.substr(0, 4), "not a .npy file");
}

TEST_F(NpyTest, RejectsWrongMagicVersionAndEmptyFile) {
  std::string bytes = ReadBytes(kData + "f8_2x3.npy");
  ExpectReadError("", "empty file");
  ExpectReadError("a,b\n1,2\n", "not a .npy file");
  std::string bad_magic = bytes;
  bad_magic[1] = 'n';
  ExpectReadError(bad_magic, "not a .npy file");
  std::string bad_version = bytes;
  bad_version[6] = '\x04';
  ExpectReadError(bad_version, "unsupported .npy format version 4.0");
  const std::string missing = Path("does_not_exist.npy");
  EXPECT_TRUE(testing::ThrowsErrorNaming([&] { ReadNpy(missing); }, missing + ": cannot open"));
}

TEST_F(NpyTest, RejectsMalformedHeaders) {
  const std::string data = DoubleBytes({1, 2});
  ExpectReadError(MakeNpy("{'descr': '<f8', 'fortran_order': False}", data), "missing key 'shape'");
  ExpectReadError(MakeNpy("{'fortran_order': False, 'shape': (2,)}", data), "missing key 'descr'");
  ExpectReadError(MakeNpy("{'descr': '<f8', 'shape': (2,)}", data), "missing key 'fortran_order'");
  ExpectReadError(MakeNpy("{'descr': '<f8', 'fortran_order': 0, 'shape': (2,)}", data), "'fortran_order' is not");
  ExpectReadError(MakeNpy("{'descr': '<f8', 'fortran_order': False, 'shape': [2]}", data), "'shape' is not a tuple");
  ExpectReadError(MakeNpy("{'descr': '<f8', 'fortran_order': False, 'shape': (2.5,)}", data), "malformed .npy header");
  ExpectReadError(MakeNpy("{'descr': '<f8', 'fortran_order': False, 'shape': ('2',)}", data), "non-integer");
  ExpectReadError(MakeNpy("{'descr': '<f8', 'fortran_order': False, 'shape': (-2,)}", data), "negative dimension");
  ExpectReadError(MakeNpy("{'descr': '<f8, 'fortran_order': False, 'shape': (2,)}", data), "malformed .npy header");
  ExpectReadError(MakeNpy("{'descr': '<f8', 'fortran_order': False, 'shape': (2,)} x", data), "unexpected text");
  ExpectReadError(MakeNpy("{'descr': '<f8' 'fortran_order': False, 'shape': (2,)}", data), "expected ',' or '}'");
  ExpectReadError(MakeNpy("{'descr': '<f8', 'fortran_order': Maybe, 'shape': (2,)}", data), "unexpected word");
  ExpectReadError(MakeNpy("('descr', '<f8')", data), "expected '{'");
  ExpectReadError(MakeNpy("{'descr': '<f8', 'fortran_order': False, 'shape': (2,", data), "malformed .npy header");
  ExpectReadError(MakeNpy(std::string(40, '('), data), "malformed .npy header");
}

TEST_F(NpyTest, AbsurdShapesFailWithoutAllocating) {
  const std::string data = DoubleBytes({1, 2});
  // The product overflows int64.
  ExpectReadError(
      MakeNpy("{'descr': '<f8', 'fortran_order': False, 'shape': (4611686018427387904, 4611686018427387904)}", data),
      "is too large");
  ExpectReadError(MakeNpy("{'descr': '<f8', 'fortran_order': False, 'shape': (1152921504606846976,)}", data),
                  "is too large");
  // A dimension beyond int64.
  ExpectReadError(MakeNpy("{'descr': '<f8', 'fortran_order': False, 'shape': (99999999999999999999,)}", data),
                  "integer out of range");
  // Representable but far larger than the file: the data-length check fires before any allocation.
  ExpectReadError(MakeNpy("{'descr': '<f8', 'fortran_order': False, 'shape': (1000000000000000,)}", data),
                  "expected 8000000000000000 bytes of data, got 16");
  ExpectReadError(MakeNpy("{'descr': '<f8', 'fortran_order': True, 'shape': (100000, 100000, 100000)}", data),
                  "expected 8000000000000000 bytes of data, got 16");
  // A zero dimension makes the product 0 whatever the others are.
  WriteBytes(Path("z.npy"), MakeNpy("{'descr': '<f8', 'fortran_order': False, 'shape': (0, 4611686018427387904)}", ""));
  EXPECT_TRUE(ReadNpy(Path("z.npy")).data.empty());
  // A version-2 header length of 4 GiB in a small file.
  std::string huge_header = "\x93NUMPY\x02";
  huge_header += std::string("\x00\xff\xff\xff\xff", 5);
  ExpectReadError(huge_header + "{}", "truncated .npy header: expected 4294967295 header bytes");
  // Too many dimensions.
  std::string many = "{'descr': '<f8', 'fortran_order': False, 'shape': (";
  for (int i = 0; i < 65; ++i) many += "1,";
  ExpectReadError(MakeNpy(many + ")}", DoubleBytes({1})), "dimensions");
}

// Random corruptions of real files either read or throw kfx::Error: no crash, no other exception,
// no huge allocation (the sanitizer build runs this too).
TEST_F(NpyTest, CorruptedFilesReadOrThrowKfxError) {
  std::mt19937 gen(12345);
  const std::vector<std::string> files = {"f8_2x3.npy", "f8_2x3x4_fortran.npy", "f8_2x3_v3.npy", "i4_vector.npy",
                                          "f8_scalar.npy"};
  int errors = 0, reads = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    std::string bytes = ReadBytes(kData + files[static_cast<std::size_t>(trial) % files.size()]);
    const int edits = 1 + static_cast<int>(gen() % 4);
    for (int e = 0; e < edits && !bytes.empty(); ++e) {
      // Mostly in the header (the first 128 bytes), where the structure is.
      const auto raw = gen();  // one draw per statement, in GCC's former order
      const bool anywhere = gen() % 4 == 0;
      const std::size_t at = raw % std::min<std::size_t>(bytes.size(), anywhere ? bytes.size() : 128);
      switch (gen() % 4) {
        case 0:
          bytes[at] = static_cast<char>(gen() & 0xff);
          break;
        case 1:
          bytes[at] = "0123456789(),' :{}"[gen() % 18];
          break;
        case 2:
          bytes.erase(at, 1 + gen() % 8);
          break;
        default:
          bytes.resize(at);
      }
    }
    WriteBytes(Path("c.npy"), bytes);
    try {
      const NpyArray a = ReadNpy(Path("c.npy"));
      std::size_t count = 1;
      for (auto d : a.shape) count *= static_cast<std::size_t>(d);
      EXPECT_EQ(a.data.size(), count);
      ++reads;
    } catch (const Error&) {
      ++errors;
    }
  }
  EXPECT_GT(errors, 1000);  // most corruptions are detected
  RecordProperty("reads", reads);
}

TEST_F(NpyTest, WriteErrorsNameThePath) {
  const std::string bad_dir = Path("no_such_dir/x.npy");
  const double x = 1.0;
  EXPECT_TRUE(
      testing::ThrowsErrorNaming([&] { WriteNpy(bad_dir, {1}, &x); }, bad_dir + ": cannot open file for writing"));
  EXPECT_THROW(WriteNpy(Path("n.npy"), {-1}, &x), Error);
  EXPECT_THROW(WriteNpy(Path("n.npy"), {2}, nullptr), Error);
  EXPECT_THROW(WriteNpy(Path("n.npy"), {4611686018427387904, 4}, &x), Error);
}

}  // namespace
}  // namespace kfx
