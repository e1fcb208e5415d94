// NumPy .npy reader and writer (format: docs/formats.md, and NumPy's NEP 1,
// numpy/lib/format.py). Only what kfx needs: numeric arrays, read as double.
//
// Safety: nothing is allocated from a size found in a header before it has been checked against the
// size of the file, so a corrupt or hostile header cannot make the reader allocate unbounded memory.
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "io/io_internal.hpp"
#include "kfx/error.hpp"
#include "kfx/io.hpp"

namespace kfx {

namespace {

constexpr char kMagic[] = "\x93NUMPY";
constexpr std::size_t kMagicLength = 6;
constexpr int kMaxDimensions = 64;  // numpy 1.x allows 32, numpy 2.x 64.
// numpy's _write_array_header leaves room for the length of the growth axis to reach 21 digits.
constexpr std::size_t kGrowthAxisMaxDigits = 21;
constexpr std::size_t kArrayAlign = 64;
constexpr std::size_t kChunkBytes = std::size_t{1} << 20;

[[noreturn]] void Fail(const std::string& path, const std::string& what) { throw Error(path + ": " + what); }

using detail::ErrnoDetail;
using detail::NpyShapeText;

// ----- The header: a Python dict literal ---------------------------------------------------------

// A Python literal value of the kinds found in .npy headers.
struct PyValue {
  enum class Kind { kString, kBool, kInt, kNone, kSequence } kind = Kind::kNone;
  std::string text;            // kString
  bool flag = false;           // kBool
  std::int64_t integer = 0;    // kInt
  std::vector<PyValue> items;  // kSequence (tuple or list)
  bool is_list = false;        // kSequence: '[' rather than '('
};

// Recursive-descent parser for the subset of Python literal syntax numpy writes (and older numpy
// versions and other writers produce): strings, True/False/None, integers (with an optional
// Python 2 'L' suffix), tuples and lists, and one dict at the top. Whitespace and trailing commas
// are allowed wherever Python allows them.
class HeaderParser {
 public:
  HeaderParser(const std::string& path, const std::string& text) : path_(path), text_(text) {}

  std::map<std::string, PyValue> ParseDict() {
    std::map<std::string, PyValue> dict;
    SkipSpace();
    Expect('{');
    while (true) {
      SkipSpace();
      if (Peek() == '}') {
        ++pos_;
        break;
      }
      PyValue key = ParseValue(0);
      if (key.kind != PyValue::Kind::kString) Bad("expected a string key");
      SkipSpace();
      Expect(':');
      dict[key.text] = ParseValue(0);
      SkipSpace();
      if (Peek() == ',') {
        ++pos_;
      } else if (Peek() != '}') {
        Bad("expected ',' or '}'");
      }
    }
    SkipSpace();
    if (pos_ != text_.size()) Bad("unexpected text after the dict");
    return dict;
  }

 private:
  static constexpr int kMaxDepth = 32;

  char Peek() const { return pos_ < text_.size() ? text_[pos_] : '\0'; }
  void SkipSpace() {
    while (pos_ < text_.size() && std::isspace(static_cast<unsigned char>(text_[pos_]))) ++pos_;
  }
  void Expect(char c) {
    if (Peek() != c) Bad(std::string("expected '") + c + "'");
    ++pos_;
  }
  [[noreturn]] void Bad(const std::string& what) const {
    Fail(path_, "malformed .npy header: " + what + " at offset " + std::to_string(pos_) + " in " + Quoted(text_));
  }
  static std::string Quoted(const std::string& s) {
    std::string out = "\"";
    for (char c : s.substr(0, 200)) {
      if (c == '\n') {
        out += "\\n";
      } else if (std::isprint(static_cast<unsigned char>(c))) {
        out += c;
      } else {
        out += '?';
      }
    }
    return out + (s.size() > 200 ? "...\"" : "\"");
  }

  PyValue ParseValue(int depth) {
    if (depth > kMaxDepth) Bad("nesting too deep");
    SkipSpace();
    const char c = Peek();
    PyValue v;
    if (c == '\'' || c == '"') {
      v.kind = PyValue::Kind::kString;
      v.text = ParseString();
    } else if (c == '(' || c == '[') {
      v.kind = PyValue::Kind::kSequence;
      v.is_list = c == '[';
      const char close = c == '(' ? ')' : ']';
      ++pos_;
      while (true) {
        SkipSpace();
        if (Peek() == close) {
          ++pos_;
          break;
        }
        v.items.push_back(ParseValue(depth + 1));
        SkipSpace();
        if (Peek() == ',') {
          ++pos_;
        } else if (Peek() != close) {
          Bad(std::string("expected ',' or '") + close + "'");
        }
      }
    } else if (c == '-' || c == '+' || std::isdigit(static_cast<unsigned char>(c))) {
      v.kind = PyValue::Kind::kInt;
      v.integer = ParseInt();
    } else if (std::isalpha(static_cast<unsigned char>(c))) {
      std::string word;
      while (std::isalnum(static_cast<unsigned char>(Peek())) || Peek() == '_') word += text_[pos_++];
      if (word == "True" || word == "False") {
        v.kind = PyValue::Kind::kBool;
        v.flag = word == "True";
      } else if (word == "None") {
        v.kind = PyValue::Kind::kNone;
      } else {
        Bad("unexpected word '" + word + "'");
      }
    } else {
      Bad(c == '\0' ? std::string("unexpected end") : std::string("unexpected character '") + c + "'");
    }
    return v;
  }

  std::string ParseString() {
    const char quote = text_[pos_++];
    std::string s;
    while (true) {
      if (pos_ >= text_.size()) Bad("unterminated string");
      const char c = text_[pos_++];
      if (c == quote) break;
      if (c == '\\') {
        if (pos_ >= text_.size()) Bad("unterminated string");
        s += text_[pos_++];  // Escapes do not occur in dtype strings; keep the character.
      } else {
        s += c;
      }
    }
    return s;
  }

  std::int64_t ParseInt() {
    bool negative = false;
    if (Peek() == '-' || Peek() == '+') negative = text_[pos_++] == '-';
    if (!std::isdigit(static_cast<unsigned char>(Peek()))) Bad("expected a digit");
    // Accumulate as a negative number so that the full int64 range can be represented.
    std::int64_t value = 0;
    while (std::isdigit(static_cast<unsigned char>(Peek()))) {
      const int digit = text_[pos_++] - '0';
      if (value < (std::numeric_limits<std::int64_t>::min() + digit) / 10) Bad("integer out of range");
      value = value * 10 - digit;
    }
    if (Peek() == 'L' || Peek() == 'l') ++pos_;  // Python 2 long suffix, written by old numpy.
    if (!negative) {
      if (value == std::numeric_limits<std::int64_t>::min()) Bad("integer out of range");
      value = -value;
    }
    return value;
  }

  const std::string& path_;
  const std::string& text_;
  std::size_t pos_ = 0;
};

// ----- dtypes --------------------------------------------------------------------------------------

enum class ElementKind { kFloat, kSignedInt, kUnsignedInt, kBool };

struct DType {
  ElementKind kind;
  std::size_t size;  // bytes per element
};

std::string SupportedDTypes() { return "<f8, <f4, <i8, <i4, <i2, |i1, <u8, <u4, <u2, |u1, |b1"; }

[[noreturn]] void UnsupportedDType(const std::string& path, const std::string& descr, const std::string& why) {
  Fail(path, "unsupported dtype '" + descr + "' (" + why + "); expected one of " + SupportedDTypes());
}

DType ParseDType(const std::string& path, const PyValue& descr) {
  if (descr.kind == PyValue::Kind::kSequence) {
    Fail(path, "unsupported dtype (a structured array with named fields); expected one of " + SupportedDTypes());
  }
  if (descr.kind != PyValue::Kind::kString) Fail(path, "malformed .npy header: 'descr' is not a string");
  const std::string& d = descr.text;
  std::size_t i = 0;
  char order = '|';
  if (!d.empty() && (d[0] == '<' || d[0] == '>' || d[0] == '=' || d[0] == '|')) order = d[i++];
  if (i >= d.size()) UnsupportedDType(path, d, "no type code");
  const char code = d[i++];
  std::size_t size = 0;
  const std::string digits = d.substr(i);
  if (digits.empty() || digits.size() > 3 ||
      !std::all_of(digits.begin(), digits.end(), [](char c) { return std::isdigit(static_cast<unsigned char>(c)); })) {
    if (code == 'O') UnsupportedDType(path, d, "object array");
    UnsupportedDType(path, d, "not a plain numeric type");
  }
  size = static_cast<std::size_t>(std::stoi(digits));
  DType t{ElementKind::kFloat, size};
  switch (code) {
    case 'f':
      if (size != 4 && size != 8) UnsupportedDType(path, d, size == 2 ? "half precision" : "extended precision");
      t.kind = ElementKind::kFloat;
      break;
    case 'i':
      if (size != 1 && size != 2 && size != 4 && size != 8) UnsupportedDType(path, d, "integer size");
      t.kind = ElementKind::kSignedInt;
      break;
    case 'u':
      if (size != 1 && size != 2 && size != 4 && size != 8) UnsupportedDType(path, d, "integer size");
      t.kind = ElementKind::kUnsignedInt;
      break;
    case 'b':
      if (size != 1) UnsupportedDType(path, d, "bool size");
      t.kind = ElementKind::kBool;
      break;
    case 'c':
      UnsupportedDType(path, d, "complex");
    case 'O':
      UnsupportedDType(path, d, "object array");
    case 'U':
    case 'S':
    case 'a':
      UnsupportedDType(path, d, "string");
    case 'M':
    case 'm':
      UnsupportedDType(path, d, "date/time");
    case 'V':
      UnsupportedDType(path, d, "void/structured");
    default:
      UnsupportedDType(path, d, "unknown type code");
  }
  // '=' (the writer's native order), '|' (not applicable) and no prefix are read as little-endian:
  // numpy itself always writes '<' or '|', and kfx supports little-endian data only.
  if (order == '>' && size > 1) {
    UnsupportedDType(path, d, "big-endian; convert with arr.astype(arr.dtype.newbyteorder('<'))");
  }
  return t;
}

// Little-endian decoding, independent of the host's byte order.
std::uint64_t LoadLittleEndian(const unsigned char* p, std::size_t size) {
  std::uint64_t v = 0;
  for (std::size_t i = 0; i < size; ++i) v |= static_cast<std::uint64_t>(p[i]) << (8 * i);
  return v;
}

double DecodeElement(const unsigned char* p, const DType& t) {
  const std::uint64_t bits = LoadLittleEndian(p, t.size);
  switch (t.kind) {
    case ElementKind::kFloat:
      if (t.size == 8) {
        double d;
        std::memcpy(&d, &bits, sizeof d);
        return d;
      } else {
        const auto b32 = static_cast<std::uint32_t>(bits);
        float f;
        std::memcpy(&f, &b32, sizeof f);
        return static_cast<double>(f);
      }
    case ElementKind::kSignedInt: {
      // Sign-extend from t.size bytes.
      const unsigned shift = static_cast<unsigned>(64 - 8 * t.size);
      const auto v = static_cast<std::int64_t>(bits << shift) >> shift;
      return static_cast<double>(v);
    }
    case ElementKind::kUnsignedInt:
      return static_cast<double>(bits);
    case ElementKind::kBool:
      return bits != 0 ? 1.0 : 0.0;
  }
  return 0.0;
}

// Number of elements of `shape`, or -1 if it does not fit in int64 with `item_size` bytes each.
std::int64_t ElementCount(const std::vector<std::int64_t>& shape, std::int64_t item_size) {
  const std::int64_t max_count = std::numeric_limits<std::int64_t>::max() / item_size;
  std::int64_t count = 1;
  for (std::int64_t d : shape) {
    if (d == 0) return 0;
  }
  for (std::int64_t d : shape) {
    if (d > max_count / count) return -1;
    count *= d;
  }
  return count;
}

// Converts an array stored in Fortran (column-major) order to C (row-major) order.
std::vector<double> FortranToC(const std::vector<double>& f, const std::vector<std::int64_t>& shape) {
  const std::size_t rank = shape.size();
  if (f.empty() || rank < 2) return f;
  std::vector<double> c(f.size());
  // C strides (in elements).
  std::vector<std::int64_t> c_stride(rank, 1);
  for (std::size_t i = rank - 1; i-- > 0;) c_stride[i] = c_stride[i + 1] * shape[i + 1];
  // Walk the Fortran order: the first index varies fastest.
  std::vector<std::int64_t> index(rank, 0);
  std::int64_t c_offset = 0;
  for (double value : f) {
    c[static_cast<std::size_t>(c_offset)] = value;
    for (std::size_t axis = 0; axis < rank; ++axis) {
      if (++index[axis] < shape[axis]) {
        c_offset += c_stride[axis];
        break;
      }
      c_offset -= (shape[axis] - 1) * c_stride[axis];
      index[axis] = 0;
    }
  }
  return c;
}

void WriteAll(std::ofstream& out, const std::string& path, const char* data, std::size_t size) {
  out.write(data, static_cast<std::streamsize>(size));
  if (!out) Fail(path, "cannot write file" + ErrnoDetail());
}

// The parsed header of an open .npy file; `in` is left at the start of the data.
struct NpyHeader {
  DType dtype{ElementKind::kFloat, 8};
  bool fortran = false;
  std::vector<std::int64_t> shape;
  std::int64_t count = 0;
};

NpyHeader ReadNpyHeader(std::ifstream& in, const std::string& path) {
  in.seekg(0, std::ios::end);
  const std::streamoff file_size = in.tellg();
  in.seekg(0, std::ios::beg);
  if (file_size < 0 || !in) Fail(path, "cannot determine the file size (not a regular file?)");
  if (file_size == 0) Fail(path, "empty file, expected a .npy array");

  // Preamble: magic, version, header length.
  char preamble[12];
  const std::size_t fixed = std::min<std::size_t>(static_cast<std::size_t>(file_size), 10);
  in.read(preamble, static_cast<std::streamsize>(fixed));
  if (fixed < kMagicLength || std::memcmp(preamble, kMagic, kMagicLength) != 0) {
    Fail(path, "not a .npy file (expected the magic string \\x93NUMPY at the start)");
  }
  if (fixed < 10) Fail(path, "truncated .npy header (file has " + std::to_string(file_size) + " bytes)");
  const int major = static_cast<unsigned char>(preamble[6]);
  const int minor = static_cast<unsigned char>(preamble[7]);
  std::uint64_t header_length = 0;
  std::size_t preamble_length = 0;
  if (major == 1 && minor == 0) {
    header_length = LoadLittleEndian(reinterpret_cast<const unsigned char*>(preamble + 8), 2);
    preamble_length = 10;
  } else if ((major == 2 || major == 3) && minor == 0) {
    if (file_size < 12) Fail(path, "truncated .npy header (file has " + std::to_string(file_size) + " bytes)");
    in.read(preamble + 10, 2);
    header_length = LoadLittleEndian(reinterpret_cast<const unsigned char*>(preamble + 8), 4);
    preamble_length = 12;
  } else {
    Fail(path, "unsupported .npy format version " + std::to_string(major) + "." + std::to_string(minor) +
                   " (expected 1.0, 2.0 or 3.0)");
  }
  const auto after_preamble = static_cast<std::uint64_t>(file_size) - preamble_length;
  if (header_length > after_preamble) {
    Fail(path, "truncated .npy header: expected " + std::to_string(header_length) + " header bytes, got " +
                   std::to_string(after_preamble));
  }
  std::string header(static_cast<std::size_t>(header_length), '\0');
  in.read(header.data(), static_cast<std::streamsize>(header.size()));
  if (!in) Fail(path, "cannot read the .npy header");

  const std::map<std::string, PyValue> dict = HeaderParser(path, header).ParseDict();
  const auto field = [&](const char* key) -> const PyValue& {
    auto it = dict.find(key);
    if (it == dict.end()) Fail(path, std::string("malformed .npy header: missing key '") + key + "'");
    return it->second;
  };
  const DType dtype = ParseDType(path, field("descr"));
  const PyValue& fortran = field("fortran_order");
  if (fortran.kind != PyValue::Kind::kBool) Fail(path, "malformed .npy header: 'fortran_order' is not True/False");
  const PyValue& shape_value = field("shape");
  if (shape_value.kind != PyValue::Kind::kSequence || shape_value.is_list) {
    Fail(path, "malformed .npy header: 'shape' is not a tuple");
  }
  if (shape_value.items.size() > static_cast<std::size_t>(kMaxDimensions)) {
    Fail(path, "unsupported .npy array with " + std::to_string(shape_value.items.size()) + " dimensions (at most " +
                   std::to_string(kMaxDimensions) + ")");
  }
  NpyHeader array;
  array.dtype = dtype;
  array.fortran = fortran.flag;
  for (const PyValue& d : shape_value.items) {
    if (d.kind != PyValue::Kind::kInt) Fail(path, "malformed .npy header: 'shape' holds a non-integer");
    array.shape.push_back(d.integer);
  }
  for (std::int64_t d : array.shape) {
    if (d < 0) Fail(path, "malformed .npy header: negative dimension in shape " + NpyShapeText(array.shape));
  }
  const auto item_size = static_cast<std::int64_t>(dtype.size);
  const std::int64_t count = ElementCount(array.shape, item_size);
  if (count < 0) Fail(path, "malformed .npy header: shape " + NpyShapeText(array.shape) + " is too large");

  // Check the data length before allocating anything of the header's size.
  const std::uint64_t expected_bytes = static_cast<std::uint64_t>(count) * dtype.size;
  const std::uint64_t data_bytes = after_preamble - header_length;
  if (data_bytes != expected_bytes) {
    Fail(path, "expected " + std::to_string(expected_bytes) + " bytes of data, got " + std::to_string(data_bytes) +
                   " (shape " + NpyShapeText(array.shape) + ", dtype '" + field("descr").text + "')");
  }
  if (static_cast<std::uint64_t>(count) > std::numeric_limits<std::size_t>::max() / sizeof(double)) {
    Fail(path, "array too large for this platform");
  }

  array.count = count;
  return array;
}

// Reads `count` elements at the current position into out (converted to double).
void ReadElements(std::ifstream& in, const std::string& path, const DType& dtype, std::size_t count, double* out) {
  std::vector<unsigned char> chunk;
  const std::size_t per_chunk = std::max<std::size_t>(1, kChunkBytes / dtype.size);
  for (std::size_t start = 0; start < count; start += per_chunk) {
    const std::size_t n = std::min(per_chunk, count - start);
    chunk.resize(n * dtype.size);
    in.read(reinterpret_cast<char*>(chunk.data()), static_cast<std::streamsize>(chunk.size()));
    if (!in) Fail(path, "cannot read the array data");
    for (std::size_t i = 0; i < n; ++i) out[start + i] = DecodeElement(chunk.data() + i * dtype.size, dtype);
  }
}

std::ifstream OpenNpy(const std::string& path) {
  detail::RequireRegularFile(path, "a .npy file");
  errno = 0;
  std::ifstream in(path, std::ios::binary);
  if (!in) Fail(path, "cannot open file for reading" + ErrnoDetail());
  return in;
}

}  // namespace

NpyArray ReadNpy(const std::string& path) {
  std::ifstream in = OpenNpy(path);
  const NpyHeader h = ReadNpyHeader(in, path);
  NpyArray array;
  array.shape = h.shape;
  array.data.resize(static_cast<std::size_t>(h.count));
  ReadElements(in, path, h.dtype, array.data.size(), array.data.data());
  if (h.fortran) array.data = FortranToC(array.data, array.shape);
  return array;
}

NpyArray ReadNpySlice(const std::string& path, int axis, std::int64_t start, std::int64_t count) {
  std::ifstream in = OpenNpy(path);
  const NpyHeader h = ReadNpyHeader(in, path);
  const int ndim = static_cast<int>(h.shape.size());
  if (axis < 0 || axis >= ndim) {
    Fail(path, "cannot slice axis " + std::to_string(axis) + " of an array of shape " + NpyShapeText(h.shape));
  }
  const std::int64_t len = h.shape[static_cast<size_t>(axis)];
  if (start < 0 || count < 0 || start > len || count > len - start) {
    Fail(path, "slice [" + std::to_string(start) + ", " + std::to_string(start + count) + ") of axis " +
                   std::to_string(axis) + " is outside the shape " + NpyShapeText(h.shape));
  }
  // In file order the array has shape h.shape (C order) or its reverse (Fortran order): the slice is
  // `outer` runs of count * inner contiguous elements, `len * inner` apart.
  std::vector<std::int64_t> file_shape = h.shape;
  int file_axis = axis;
  if (h.fortran) {
    std::reverse(file_shape.begin(), file_shape.end());
    file_axis = ndim - 1 - axis;
  }
  std::int64_t outer = 1, inner = 1;
  for (int a = 0; a < file_axis; ++a) outer *= file_shape[static_cast<size_t>(a)];
  for (int a = file_axis + 1; a < ndim; ++a) inner *= file_shape[static_cast<size_t>(a)];
  NpyArray array;
  array.shape = h.shape;
  array.shape[static_cast<size_t>(axis)] = count;
  array.data.resize(static_cast<std::size_t>(outer * count * inner));
  const std::streamoff data_start = in.tellg();
  const auto item = static_cast<std::streamoff>(h.dtype.size);
  for (std::int64_t o = 0; o < outer && count > 0; ++o) {
    in.seekg(data_start + ((o * len + start) * inner) * item);
    if (!in) Fail(path, "cannot seek in the array data");
    ReadElements(in, path, h.dtype, static_cast<std::size_t>(count * inner),
                 array.data.data() + static_cast<std::size_t>(o * count * inner));
  }
  if (h.fortran) array.data = FortranToC(array.data, array.shape);
  return array;
}

void WriteNpy(const std::string& path, const std::vector<std::int64_t>& shape, const double* data) {
  for (std::int64_t d : shape) {
    if (d < 0) Fail(path, "shape: expected non-negative dimensions, got " + NpyShapeText(shape));
  }
  if (shape.size() > static_cast<std::size_t>(kMaxDimensions)) {
    Fail(path, "shape: expected at most " + std::to_string(kMaxDimensions) + " dimensions, got " +
                   std::to_string(shape.size()));
  }
  const std::int64_t count = ElementCount(shape, static_cast<std::int64_t>(sizeof(double)));
  if (count < 0) Fail(path, "shape: " + NpyShapeText(shape) + " is too large");
  if (count > 0 && data == nullptr) Fail(path, "data: expected " + std::to_string(count) + " values, got null");

  // The header exactly as numpy.save writes it (numpy/lib/format.py, _write_array_header): the dict
  // with sorted keys, room for the first axis to grow to 21 digits, then spaces up to a multiple of
  // 64 bytes and a final '\n'.
  std::string header = "{'descr': '<f8', 'fortran_order': False, 'shape': " + NpyShapeText(shape) + ", }";
  if (!shape.empty()) {
    const std::size_t digits = std::to_string(shape[0]).size();
    header.append(kGrowthAxisMaxDigits > digits ? kGrowthAxisMaxDigits - digits : 0, ' ');
  }
  // Version 1.0 (2-byte header length): with at most kMaxDimensions dimensions the header is far
  // below 64 KiB.
  const std::size_t length_bytes = 2;
  std::string preamble(kMagic, kMagicLength);
  preamble += std::string("\x01\x00", 2);
  const std::size_t padding = kArrayAlign - (kMagicLength + 2 + length_bytes + header.size() + 1) % kArrayAlign;
  header.append(padding, ' ');
  header += '\n';
  KFX_ASSERT(header.size() <= 0xffff);
  const std::uint64_t header_length = header.size();
  for (std::size_t i = 0; i < length_bytes; ++i) preamble += static_cast<char>((header_length >> (8 * i)) & 0xff);

  AtomicOutputFile file(path);
  std::ofstream& out = file.stream();
  WriteAll(out, path, preamble.data(), preamble.size());
  WriteAll(out, path, header.data(), header.size());
  std::vector<unsigned char> chunk;
  const std::size_t per_chunk = kChunkBytes / sizeof(double);
  const auto total = static_cast<std::size_t>(count);
  for (std::size_t start = 0; start < total; start += per_chunk) {
    const std::size_t n = std::min(per_chunk, total - start);
    chunk.resize(n * sizeof(double));
    for (std::size_t i = 0; i < n; ++i) {
      std::uint64_t bits;
      std::memcpy(&bits, data + start + i, sizeof bits);
      for (std::size_t b = 0; b < 8; ++b) chunk[i * 8 + b] = static_cast<unsigned char>((bits >> (8 * b)) & 0xff);
    }
    WriteAll(out, path, reinterpret_cast<const char*>(chunk.data()), chunk.size());
  }
  file.Commit();
}

Eigen::MatrixXd ReadNpyMatrix(const std::string& path) {
  const NpyArray a = ReadNpy(path);
  if (a.shape.size() != 1 && a.shape.size() != 2) {
    Fail(path, "expected a 1-D or 2-D array, got shape " + NpyShapeText(a.shape));
  }
  const Eigen::Index rows = a.shape[0];
  const Eigen::Index cols = a.shape.size() == 2 ? a.shape[1] : 1;
  Eigen::MatrixXd m(rows, cols);
  for (Eigen::Index i = 0; i < rows; ++i) {
    for (Eigen::Index j = 0; j < cols; ++j) m(i, j) = a.data[static_cast<std::size_t>(i * cols + j)];
  }
  return m;
}

void WriteNpyMatrix(const std::string& path, const Eigen::Ref<const Eigen::MatrixXd>& m) {
  const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> c_order = m;
  WriteNpy(path, {static_cast<std::int64_t>(m.rows()), static_cast<std::int64_t>(m.cols())}, c_order.data());
}

void WriteNpyVector(const std::string& path, const Eigen::Ref<const Eigen::VectorXd>& v) {
  const Eigen::VectorXd copy = v;
  WriteNpy(path, {static_cast<std::int64_t>(v.size())}, copy.data());
}

}  // namespace kfx
