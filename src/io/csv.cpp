// Time series files: CSV (this file) and .npy (through io_npy.cpp), chosen by extension.
// Format: docs/formats.md, "Data files".
//
// Numbers are parsed with std::from_chars and written with std::to_chars rather than strtod /
// printf("%.17g"): both are locale-independent (strtod reads "1,5" as 1.5 under a German locale and
// stops at "1.5"), from_chars is correctly rounded, and to_chars writes the shortest text that
// reads back to the same double, so a write/read round trip is exact.
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <system_error>
#include <vector>

#include "io/io_internal.hpp"
#include "kfx/error.hpp"
#include "kfx/io.hpp"

namespace kfx {

namespace {

[[noreturn]] void Fail(const std::string& path, const std::string& what) { throw Error(path + ": " + what); }

using detail::ErrnoDetail;

enum class Format { kNpy, kCsv };

Format FormatOf(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  if (ext == ".npy") return Format::kNpy;
  if (ext == ".csv") return Format::kCsv;
  Fail(path, "unknown time-series file extension '" + ext + "', expected .npy or .csv");
}

std::string Trim(const std::string& s) {
  std::size_t b = 0, e = s.size();
  while (b < e && std::isspace(static_cast<unsigned char>(s[b]))) ++b;
  while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1]))) --e;
  return s.substr(b, e - b);
}

// Trimmed fields of one line; one pair of surrounding double quotes is removed (no embedded commas).
std::vector<std::string> SplitFields(const std::string& line) {
  std::vector<std::string> fields;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    std::string f = Trim(line.substr(start, comma == std::string::npos ? std::string::npos : comma - start));
    if (f.size() >= 2 && f.front() == '"' && f.back() == '"') f = Trim(f.substr(1, f.size() - 2));
    fields.push_back(std::move(f));
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return fields;
}

// Parses a whole field as a double: a decimal or scientific number with optional sign, "inf",
// "nan" in any case, or an empty field (NaN: a missing value). Returns false for anything else.
bool ParseNumber(const std::string& field, double* value) {
  if (field.empty()) {
    *value = std::numeric_limits<double>::quiet_NaN();
    return true;
  }
  const char* first = field.data();
  const char* last = field.data() + field.size();
  // from_chars does not accept a leading '+'; strtod (and Python's float) do.
  if (*first == '+' && last - first > 1 && first[1] != '-' && first[1] != '+') ++first;
  // Text outside the range of double (e.g. 1e999, 1e-999) is result_out_of_range: rejected.
  const std::from_chars_result r = std::from_chars(first, last, *value);
  return r.ec == std::errc() && r.ptr == last;
}

std::string FormatNumber(double x) {
  if (std::isnan(x)) return "nan";
  char buf[64];
  const std::to_chars_result r = std::to_chars(buf, buf + sizeof buf, x);
  return std::string(buf, r.ptr);
}

// A field that reads as a number or tries to: a digit or '.' after an optional sign, or inf / infinity / nan
// in any case (so "1e999" and "0x10" are malformed numbers, never column names).
bool LooksNumeric(const std::string& field) {
  std::size_t i = 0;
  if (i < field.size() && (field[i] == '+' || field[i] == '-')) ++i;
  if (i < field.size() && (std::isdigit(static_cast<unsigned char>(field[i])) || field[i] == '.')) return true;
  std::string rest = field.substr(i);
  std::transform(rest.begin(), rest.end(), rest.begin(), [](unsigned char c) { return std::tolower(c); });
  return rest == "inf" || rest == "infinity" || rest == "nan" || rest.compare(0, 4, "nan(") == 0;
}

// The lines of a CSV text: ended by "\n", "\r\n" or a lone "\r" (classic Mac files), the UTF-8 byte
// order mark dropped.
std::vector<std::string> SplitLines(const std::string& text) {
  std::vector<std::string> lines;
  std::size_t start = text.compare(0, 3, "\xEF\xBB\xBF") == 0 ? 3 : 0;
  for (std::size_t i = start; i < text.size(); ++i) {
    if (text[i] != '\n' && text[i] != '\r') continue;
    lines.push_back(text.substr(start, i - start));
    if (text[i] == '\r' && i + 1 < text.size() && text[i + 1] == '\n') ++i;
    start = i + 1;
  }
  if (start < text.size()) lines.push_back(text.substr(start));
  return lines;
}

[[noreturn]] void FailField(const std::string& path, long long line_no, std::size_t column, const std::string& field) {
  std::string hint;
  if (field.find_first_of(";\t") != std::string::npos) hint = " (fields are separated by ',' only)";
  Fail(path, "line " + std::to_string(line_no) + ", column " + std::to_string(column) +
                 ": expected a number (or nan / empty for a missing value), got '" + field.substr(0, 40) +
                 (field.size() > 40 ? "...'" : "'") + hint);
}

// The rules (docs/formats.md): a header is a first line of names (none number-like, not all empty); every other line
// that is not a '#' comment is a data row with the header's (or the first row's) number of fields, each a
// number, or empty / nan for a missing value that stays in its row; a blank line inside the data is a row of
// one empty field (a missing value in a one-column file, a wrong field count otherwise); blank lines before
// the first and after the last line with text are ignored; at least one data row.
TimeSeries ReadCsv(const std::string& path, std::vector<std::string>* column_names) {
  errno = 0;
  detail::RequireRegularFile(path, "a CSV file");
  std::ifstream in(path, std::ios::binary);
  if (!in) Fail(path, "cannot open file for reading" + ErrnoDetail());
  std::ostringstream buffer;
  buffer << in.rdbuf();
  if (in.bad()) Fail(path, "cannot read file" + ErrnoDetail());
  const std::vector<std::string> lines = SplitLines(buffer.str());
  if (lines.empty()) Fail(path, "empty file, expected a CSV time series");
  auto blank = [](const std::string& l) { return Trim(l).empty(); };
  std::size_t last = lines.size();
  while (last > 0 && blank(lines[last - 1])) --last;
  std::vector<std::string> header;
  std::vector<double> values;
  std::size_t columns = 0;
  long long rows = 0;
  long long first_line = 0;  // line number of the line that fixed the column count
  for (std::size_t i = 0; i < last; ++i) {
    const long long line_no = static_cast<long long>(i) + 1;
    const std::string trimmed = Trim(lines[i]);
    if (!trimmed.empty() && trimmed[0] == '#') continue;
    if (trimmed.empty() && first_line == 0) continue;
    std::vector<std::string> fields = SplitFields(lines[i]);
    if (first_line == 0) {
      first_line = line_no;
      columns = fields.size();
      // Empty names are allowed beside others (pandas writes one for the index column).
      const bool names = std::none_of(fields.begin(), fields.end(), LooksNumeric) &&
                         std::any_of(fields.begin(), fields.end(), [](const std::string& f) { return !f.empty(); });
      if (names) {
        for (std::size_t j = 0; j < fields.size(); ++j) {
          if (fields[j].find_first_of(";\t") != std::string::npos) FailField(path, line_no, j + 1, fields[j]);
        }
        header = std::move(fields);
        continue;
      }
    } else if (fields.size() != columns) {
      Fail(path, "line " + std::to_string(line_no) + ", column " +
                     std::to_string(std::min(fields.size(), columns) + 1) + ": expected " + std::to_string(columns) +
                     " fields (as line " + std::to_string(first_line) + "), got " + std::to_string(fields.size()));
    }
    for (std::size_t j = 0; j < fields.size(); ++j) {
      double v;
      if (!ParseNumber(fields[j], &v)) FailField(path, line_no, j + 1, fields[j]);
      values.push_back(v);
    }
    ++rows;
  }
  if (first_line == 0) Fail(path, "no data: the file holds only blank and comment lines");
  if (rows == 0) Fail(path, "no data rows (a header line alone), expected at least one row");
  if (column_names != nullptr) *column_names = header;
  TimeSeries data(static_cast<Eigen::Index>(rows), static_cast<Eigen::Index>(columns));
  std::copy(values.begin(), values.end(), data.data());  // row-major, as read
  return data;
}

void WriteCsv(const std::string& path, const TimeSeries& data, const std::vector<std::string>& column_names) {
  if (!column_names.empty()) {
    if (static_cast<Eigen::Index>(column_names.size()) != data.cols()) {
      Fail(path, "column_names: expected " + std::to_string(data.cols()) + " names (one per column), got " +
                     std::to_string(column_names.size()));
    }
    for (std::size_t j = 0; j < column_names.size(); ++j) {
      const std::string& name = column_names[j];
      const std::string label = "column_names[" + std::to_string(j) + "]";
      if (name.find_first_of(",\"\r\n") != std::string::npos) {
        Fail(path, label + ": expected a name without ',', '\"' or line breaks, got '" + name + "'");
      }
      if (Trim(name).empty() || LooksNumeric(Trim(name)) || name.find_first_of(";\t") != std::string::npos) {
        Fail(path, label +
                       ": expected a name that is not empty, not number-like and without ';' or tab (it would "
                       "not be read back as a name), got '" +
                       name + "'");
      }
      if (j == 0 && Trim(name)[0] == '#') Fail(path, label + ": expected a name not starting with '#'");
    }
  }
  if (data.rows() == 0)
    Fail(path, "data: expected at least one row (a CSV time series without rows does not read back)");
  if (data.cols() == 0 && data.rows() > 0) Fail(path, "data: expected at least one column for a CSV file");

  AtomicOutputFile file(path);
  std::ofstream& out = file.stream();
  std::string text;
  if (!column_names.empty()) {
    for (std::size_t j = 0; j < column_names.size(); ++j) text += (j > 0 ? "," : "") + Trim(column_names[j]);
    text += '\n';
  }
  for (Eigen::Index i = 0; i < data.rows(); ++i) {
    for (Eigen::Index j = 0; j < data.cols(); ++j) {
      if (j > 0) text += ',';
      text += FormatNumber(data(i, j));
    }
    text += '\n';
    if (text.size() > (std::size_t{1} << 20)) {
      out << text;
      text.clear();
    }
  }
  out << text;
  file.Commit();
}

}  // namespace

TimeSeries ReadTimeSeries(const std::string& path, std::vector<std::string>* column_names) {
  if (column_names != nullptr) column_names->clear();
  if (FormatOf(path) == Format::kCsv) return ReadCsv(path, column_names);
  const NpyArray a = ReadNpy(path);
  if (a.shape.size() != 1 && a.shape.size() != 2) {
    std::string shape;
    for (std::size_t i = 0; i < a.shape.size(); ++i) shape += (i > 0 ? ", " : "") + std::to_string(a.shape[i]);
    Fail(path, "expected a time series of shape (T, m) or (T,), got shape (" + shape + ")");
  }
  const Eigen::Index rows = a.shape[0];
  const Eigen::Index cols = a.shape.size() == 2 ? a.shape[1] : 1;
  TimeSeries data(rows, cols);
  std::copy(a.data.begin(), a.data.end(), data.data());  // both C order
  return data;
}

TimeSeries ReadTimeSeries(const std::string& path) { return ReadTimeSeries(path, nullptr); }

void WriteTimeSeries(const std::string& path, const TimeSeries& data, const std::vector<std::string>& column_names) {
  if (FormatOf(path) == Format::kCsv) {
    WriteCsv(path, data, column_names);
    return;
  }
  if (!column_names.empty() && static_cast<Eigen::Index>(column_names.size()) != data.cols()) {
    Fail(path, "column_names: expected " + std::to_string(data.cols()) + " names (one per column), got " +
                   std::to_string(column_names.size()));
  }
  WriteNpy(path, {static_cast<std::int64_t>(data.rows()), static_cast<std::int64_t>(data.cols())}, data.data());
}

}  // namespace kfx
