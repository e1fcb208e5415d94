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

bool IsNumberText(const std::string& field) {
  double v;
  return !field.empty() && ParseNumber(field, &v);
}

std::string FormatNumber(double x) {
  if (std::isnan(x)) return "nan";
  char buf[64];
  const std::to_chars_result r = std::to_chars(buf, buf + sizeof buf, x);
  return std::string(buf, r.ptr);
}

TimeSeries ReadCsv(const std::string& path, std::vector<std::string>* column_names) {
  errno = 0;
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) Fail(path, "is a directory, expected a CSV file");
  std::ifstream in(path, std::ios::binary);
  if (!in) Fail(path, "cannot open file for reading" + ErrnoDetail());
  std::vector<std::string> header;
  std::vector<double> values;
  std::size_t columns = 0;
  long long rows = 0;
  long long first_line = 0;  // line number of the line that fixed the column count
  bool any_line = false;
  std::string line;
  for (long long line_no = 1; std::getline(in, line); ++line_no) {
    any_line = true;
    if (line_no == 1 && line.compare(0, 3, "\xEF\xBB\xBF") == 0) line.erase(0, 3);  // UTF-8 byte order mark
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const std::string trimmed = Trim(line);
    if (trimmed.empty() || trimmed[0] == '#') continue;
    std::vector<std::string> fields = SplitFields(line);
    const std::string where = "line " + std::to_string(line_no);
    if (first_line == 0) {
      first_line = line_no;
      columns = fields.size();
      // A header is a first line with at least one name and no number in it.
      const bool has_text = std::any_of(fields.begin(), fields.end(), [](const std::string& f) {
        double v;
        return !ParseNumber(f, &v);
      });
      const bool has_number = std::any_of(fields.begin(), fields.end(), IsNumberText);
      if (has_text && !has_number) {
        header = std::move(fields);
        continue;
      }
    } else if (fields.size() != columns) {
      Fail(path, where + ": expected " + std::to_string(columns) + " fields (as line " + std::to_string(first_line) +
                     "), got " + std::to_string(fields.size()));
    }
    for (std::size_t j = 0; j < fields.size(); ++j) {
      double v;
      if (!ParseNumber(fields[j], &v)) {
        std::string shown = fields[j].substr(0, 40);
        Fail(path, where + ", column " + std::to_string(j + 1) +
                       ": expected a number (or nan / empty for a "
                       "missing value), got '" +
                       shown + (fields[j].size() > 40 ? "...'" : "'"));
      }
      values.push_back(v);
    }
    ++rows;
  }
  if (in.bad()) Fail(path, "cannot read file" + ErrnoDetail());
  if (!any_line) Fail(path, "empty file, expected a CSV time series");
  if (first_line == 0) Fail(path, "no data: the file holds only blank and comment lines");
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
      double v;
      if (Trim(name).empty() || ParseNumber(Trim(name), &v)) {
        Fail(path, label +
                       ": expected a name that is not empty and not a number (it would be read back as "
                       "data), got '" +
                       name + "'");
      }
      if (j == 0 && Trim(name)[0] == '#') Fail(path, label + ": expected a name not starting with '#'");
    }
  } else if (data.rows() == 0) {
    Fail(path, "data: a CSV file without column names needs at least one row");
  }
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
