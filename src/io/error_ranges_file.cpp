// The error-ranges file (include/kfx/error_ranges_file.hpp; format: docs/formats.md, "Error ranges").
#include "kfx/error_ranges_file.hpp"

#include <string>

#include "io/json_matrix.hpp"
#include "kfx/error.hpp"
#include "kfx/mismatch.hpp"

namespace kfx {

ErrorRanges LoadErrorRanges(const std::string& path, const ModelStep& design) {
  const detail::Json j = detail::ReadJsonObject(path, "kfx-error-ranges");
  detail::CheckJsonFormat(j, path, "kfx-error-ranges", /*required=*/false);
  detail::CheckJsonVersion(j, path, 1);
  ErrorRanges r;
  Eigen::MatrixXd* fields[5] = {&r.A, &r.C, &r.Q, &r.R, &r.S};
  const char* names[5] = {"A", "C", "Q", "R", "S"};
  for (int k = 0; k < 5; ++k) {
    if (j.contains(names[k])) *fields[k] = detail::JsonMatrix(j[names[k]], {path, names[k], ""});
  }
  if (j.contains("unmodelled_input")) {
    if (!j["unmodelled_input"].is_boolean()) {
      throw Error(path + ": unmodelled_input: expected true or false, got " + j["unmodelled_input"].dump());
    }
    r.unmodelled_input = j["unmodelled_input"].get<bool>();
  }
  if (r.A.size() + r.C.size() + r.Q.size() + r.R.size() + r.S.size() == 0 && !r.unmodelled_input) {
    throw Error(path + ": expected at least one of the fields 'A', 'C', 'Q', 'R', 'S', 'unmodelled_input'");
  }
  try {
    ValidateErrorRanges(design, r);
  } catch (const Error& e) {
    throw Error(path + ": " + e.what());
  }
  return r;
}

}  // namespace kfx
