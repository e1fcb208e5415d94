// The continuous-time model file (include/kfx/continuous_model_file.hpp; format: docs/formats.md,
// "Continuous-time model files").
#include "kfx/continuous_model_file.hpp"

#include <cmath>

#include "io/json_matrix.hpp"
#include "kfx/error.hpp"
#include "kfx/io.hpp"

namespace kfx {

namespace {

constexpr const char* kFormat = "kfx-continuous-model";

Eigen::MatrixXd Matrix(const detail::Json& root, const std::string& path, const std::string& key) {
  const detail::JsonField field{path, key, ""};
  if (!root.contains(key)) field.Fail("missing (a " + std::string(kFormat) + " file needs A, C, R, Q, m0, P0, dt)");
  const detail::Json& v = root[key];
  if (v.is_object()) {
    try {
      return ReadNpyMatrix(detail::JsonNpyReference(v, field));
    } catch (const Error& e) {
      field.Fail(e.what());
    }
  }
  return detail::JsonMatrix(v, field);
}

}  // namespace

bool IsContinuousModelFile(const std::string& path) { return JsonFileFormat(path) == kFormat; }

ContinuousModelFile LoadContinuousModel(const std::string& path) {
  const detail::Json j = detail::ReadJsonObject(path, kFormat);
  detail::CheckJsonFormat(j, path, kFormat, /*required=*/true);
  detail::CheckJsonVersion(j, path, 1);
  ContinuousModelFile f;
  ContinuousModel& m = f.model;
  m.A = Matrix(j, path, "A");
  m.C = Matrix(j, path, "C");
  m.R = Matrix(j, path, "R");
  m.Q = Matrix(j, path, "Q");
  // B defaults to the identity: Q is then the incremental covariance of the state noise itself.
  m.B = j.contains("B") ? Matrix(j, path, "B") : Eigen::MatrixXd::Identity(m.A.rows(), m.A.rows());
  const detail::JsonField m0{path, "m0", ""};
  if (!j.contains("m0")) m0.Fail("missing (a " + std::string(kFormat) + " file needs A, C, R, Q, m0, P0, dt)");
  m.m0 = detail::JsonVector(j["m0"], m0);
  m.P0 = Matrix(j, path, "P0");
  const detail::JsonField dt{path, "dt", ""};
  if (!j.contains("dt")) dt.Fail("missing: the sampling step of the data (a number > 0)");
  if (!j["dt"].is_number() || !std::isfinite(j["dt"].get<double>()) || !(j["dt"].get<double>() > 0)) {
    dt.Fail("expected a finite number > 0 (the sampling step of the data), got " + detail::JsonBrief(j["dt"]));
  }
  f.dt = j["dt"].get<double>();
  try {
    ValidateContinuousModel(m);
  } catch (const Error& e) {
    // "R: expected ..." -> "FILE: field 'R': expected ...".
    const std::string what = e.what();
    const std::size_t colon = what.find(": ");
    if (colon == std::string::npos || colon > 4) throw Error(path + ": " + what);
    detail::JsonField{path, what.substr(0, colon), ""}.Fail(what.substr(colon + 2));
  }
  return f;
}

Model SampledAtFileGrid(const ContinuousModelFile& file) {
  const Model one = SampledModel(file.model, file.dt, 1);
  return Model(*one.step(1), one.m0(), one.P0());
}

Model LoadModelOrSampled(const std::string& path) {
  return IsContinuousModelFile(path) ? SampledAtFileGrid(LoadContinuousModel(path)) : LoadModel(path);
}

}  // namespace kfx
