// The JSON side of kfx's file formats: the file, its header fields, and the one set of rules for inline
// matrices and vectors (src/io/json_matrix.hpp; docs/formats.md, "Matrices and vectors in JSON files").
#include "io/json_matrix.hpp"

#include <cerrno>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <system_error>

#include "io/io_internal.hpp"
#include "kfx/error.hpp"
#include "kfx/io.hpp"
#include "kfx/validation.hpp"

namespace kfx::detail {

using Eigen::Index;
using Eigen::MatrixXd;
using Eigen::VectorXd;
namespace fs = std::filesystem;

namespace {

constexpr int kMaxCountedDepth = 9;

[[noreturn]] void FailFile(const std::string& path, const std::string& what) { throw Error(path + ": " + what); }

std::string ObjectExample(const std::string& format) { return "a JSON object {\"format\": \"" + format + "\", ...}"; }

// One entry: a finite number. `where` names it ("row 2, column 1"; empty for a lone number).
double Entry(const Json& x, const JsonField& field, const std::string& where) {
  const std::string in = where.empty() ? std::string() : " in " + where;
  if (!x.is_number()) field.Fail("expected a number" + in + ", got " + JsonBrief(x));
  const double value = x.get<double>();
  if (!std::isfinite(value)) field.Fail("expected a finite number" + in + ", got " + std::to_string(value));
  return value;
}

}  // namespace

std::string JsonField::Label() const { return file + ": field '" + name + "'"; }

void JsonField::Fail(const std::string& what) const { throw Error(Label() + ": " + context + what); }

std::string JsonBrief(const Json& v) {
  if (v.is_null()) return "null";
  std::string text = v.dump();
  if (text.size() > 40) text = text.substr(0, 40) + "...";
  return std::string(v.type_name()) + " " + text;
}

Json ReadJsonObject(const std::string& path, const std::string& format) {
  errno = 0;
  RequireRegularFile(path, ObjectExample(format));
  std::ifstream in(path, std::ios::binary);
  if (!in) FailFile(path, "cannot open file for reading" + ErrnoDetail());
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) FailFile(path, "cannot read file");
  if (text.str().find_first_not_of(" \t\r\n") == std::string::npos) {
    FailFile(path, "empty file, expected " + ObjectExample(format));
  }
  Json root;
  try {
    root = Json::parse(text.str());
  } catch (const Json::exception& e) {
    // "[json.exception.parse_error.101] parse error at line 3, column 7: ..." -> drop the tag.
    std::string what = e.what();
    const std::size_t tag_end = what.find("] ");
    if (what.compare(0, 1, "[") == 0 && tag_end != std::string::npos) what = what.substr(tag_end + 2);
    FailFile(path, "invalid JSON: " + what);
  }
  if (!root.is_object()) FailFile(path, "expected " + ObjectExample(format) + ", got " + JsonBrief(root));
  return root;
}

void CheckJsonFormat(const Json& root, const std::string& path, const std::string& format, bool required) {
  if (!root.contains("format")) {
    if (required) FailFile(path, "missing field 'format' (expected \"" + format + "\")");
    return;
  }
  const Json& f = root["format"];
  if (!f.is_string() || f.get<std::string>() != format) {
    JsonField{path, "format", ""}.Fail("expected \"" + format + "\", got " + JsonBrief(f));
  }
}

void CheckJsonVersion(const Json& root, const std::string& path, int version) {
  if (!root.contains("version")) return;
  const Json& v = root["version"];
  if (!v.is_number() || v.get<double>() != version) {
    JsonField{path, "version", ""}.Fail("unsupported version " + v.dump() + " (this kfx reads version " +
                                        std::to_string(version) + ")");
  }
}

Index JsonIndex(const Json& root, const std::string& path, const std::string& key, Index min) {
  if (!root.contains(key)) FailFile(path, "missing field '" + key + "'");
  const Json& v = root[key];
  if (!v.is_number_integer() || v.get<long long>() < min) {
    JsonField{path, key, ""}.Fail("expected an integer >= " + std::to_string(min) + ", got " + JsonBrief(v));
  }
  return v.get<Index>();
}

int JsonListDepth(const Json& v) {
  int depth = 0;
  const Json* p = &v;
  while (p->is_array() && !p->empty() && depth < kMaxCountedDepth - 1) {
    ++depth;
    p = &p->front();
  }
  return p->is_array() ? depth + 1 : depth;
}

MatrixXd JsonMatrix(const Json& v, const JsonField& field) {
  if (v.is_number()) return MatrixXd::Constant(1, 1, Entry(v, field, ""));
  if (!v.is_array()) field.Fail("expected a matrix as a list of rows, got " + JsonBrief(v));
  if (v.empty()) field.Fail("expected a matrix as a list of rows (e.g. [[1, 0]]), got an empty list");
  const int depth = JsonListDepth(v);
  if (depth == 1) field.Fail("expected a matrix as a list of rows (e.g. [[1, 0]] for one row), got a flat list");
  if (depth > 2) {
    field.Fail("expected a matrix (a list of rows), got lists nested " + std::to_string(depth) + " deep");
  }
  const auto rows = static_cast<Index>(v.size());
  const auto cols = static_cast<Index>(v.front().size());
  MatrixXd m(rows, cols);
  for (Index i = 0; i < rows; ++i) {
    const Json& row = v[static_cast<std::size_t>(i)];
    const std::string row_label = "row " + std::to_string(i + 1);
    if (!row.is_array()) field.Fail("expected a list of numbers in " + row_label + ", got " + JsonBrief(row));
    if (row.empty()) field.Fail("expected at least one number in " + row_label + ", got an empty list");
    if (static_cast<Index>(row.size()) != cols) {
      field.Fail(row_label + " has " + std::to_string(row.size()) + " entries, expected " + std::to_string(cols) +
                 " (as row 1)");
    }
    for (Index j = 0; j < cols; ++j) {
      m(i, j) = Entry(row[static_cast<std::size_t>(j)], field, row_label + ", column " + std::to_string(j + 1));
    }
  }
  return m;
}

MatrixXd JsonMatrix(const Json& v, const JsonField& field, Index rows, Index cols) {
  if (v.is_array() && v.empty() && rows * cols == 0) return MatrixXd(rows, cols);
  MatrixXd m = JsonMatrix(v, field);
  if (m.rows() != rows || m.cols() != cols) {
    field.Fail("expected a " + ShapeString(rows, cols) + " matrix, got " + ShapeString(m));
  }
  return m;
}

VectorXd JsonVector(const Json& v, const JsonField& field) {
  if (v.is_number()) return VectorXd::Constant(1, Entry(v, field, ""));
  if (!v.is_array()) field.Fail("expected a vector as a list of numbers, got " + JsonBrief(v));
  if (v.empty()) field.Fail("expected a vector as a list of numbers, got an empty list");
  const int depth = JsonListDepth(v);
  if (depth == 2) {
    const MatrixXd column = JsonMatrix(v, field);
    if (column.cols() != 1) {
      field.Fail("expected a vector (a list of numbers, or a column [[1], [2]]), got a " + ShapeString(column) +
                 " matrix");
    }
    return column.col(0);
  }
  if (depth > 2)
    field.Fail("expected a vector as a list of numbers, got lists nested " + std::to_string(depth) + " deep");
  VectorXd x(static_cast<Index>(v.size()));
  for (std::size_t i = 0; i < v.size(); ++i) {
    x(static_cast<Index>(i)) = Entry(v[i], field, "entry " + std::to_string(i + 1));
  }
  return x;
}

std::string JsonNpyReference(const Json& v, const JsonField& field) {
  if (!v.is_object() || v.size() != 1 || !v.contains("npy") || !v["npy"].is_string()) {
    field.Fail("expected {\"npy\": \"file.npy\"}, got " + JsonBrief(v));
  }
  fs::path file = v["npy"].get<std::string>();
  if (file.is_relative()) file = fs::path(field.file).parent_path() / file;
  return file.string();
}

}  // namespace kfx::detail

namespace kfx {

std::string JsonFileFormat(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return "";  // a FIFO would block the open
  std::ifstream in(path, std::ios::binary);
  if (!in) return "";
  std::ostringstream text;
  text << in.rdbuf();
  const detail::Json j = detail::Json::parse(text.str(), nullptr, /*allow_exceptions=*/false);
  return j.is_object() && j.contains("format") && j["format"].is_string() ? j["format"].get<std::string>() : "";
}

}  // namespace kfx
