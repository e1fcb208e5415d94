// The error-ranges file (include/kfx/error_ranges_file.hpp; format: docs/formats.md, "Error ranges").
#include "kfx/error_ranges_file.hpp"

#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "kfx/error.hpp"
#include "kfx/mismatch.hpp"

namespace kfx {

using Eigen::Index;
using Eigen::MatrixXd;

namespace {

MatrixXd JsonMatrix(const nlohmann::json& j, const std::string& where) {
  if (j.is_number()) return MatrixXd::Constant(1, 1, j.get<double>());
  if (!j.is_array() || j.empty() || !j[0].is_array()) {
    throw Error(where + ": expected a matrix (a list of rows, or a number for 1 x 1)");
  }
  const Index rows = static_cast<Index>(j.size()), cols = static_cast<Index>(j[0].size());
  MatrixXd m(rows, cols);
  for (Index i = 0; i < rows; ++i) {
    const auto& row = j[static_cast<size_t>(i)];
    if (!row.is_array() || static_cast<Index>(row.size()) != cols) {
      throw Error(where + ": row " + std::to_string(i + 1) + ": expected " + std::to_string(cols) + " entries");
    }
    for (Index c = 0; c < cols; ++c) {
      const auto& x = row[static_cast<size_t>(c)];
      if (!x.is_number()) throw Error(where + ": expected numbers");
      m(i, c) = x.get<double>();
    }
  }
  return m;
}

}  // namespace

ErrorRanges LoadErrorRanges(const std::string& path, const ModelStep& design) {
  std::ifstream in(path);
  if (!in) throw Error(path + ": cannot open file");
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw Error(path + ": invalid JSON: " + e.what());
  }
  if (!j.is_object()) throw Error(path + ": expected a JSON object");
  if (j.contains("format") && j["format"] != "kfx-error-ranges") {
    throw Error(path + ": field 'format': expected \"kfx-error-ranges\"");
  }
  if (j.contains("version") && j["version"] != 1) throw Error(path + ": field 'version': expected 1");
  ErrorRanges r;
  MatrixXd* fields[4] = {&r.A, &r.C, &r.Q, &r.R};
  const char* names[4] = {"A", "C", "Q", "R"};
  for (int k = 0; k < 4; ++k) {
    if (j.contains(names[k])) {
      *fields[k] = JsonMatrix(j[names[k]], path + ": field '" + names[k] + "'");
    }
  }
  if (r.A.size() + r.C.size() + r.Q.size() + r.R.size() == 0) {
    throw Error(path + ": expected at least one of the fields 'A', 'C', 'Q', 'R'");
  }
  try {
    ValidateErrorRanges(design, r);
  } catch (const Error& e) {
    throw Error(path + ": " + e.what());
  }
  return r;
}

}  // namespace kfx
