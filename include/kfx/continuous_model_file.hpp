#pragma once
// The continuous-time model file (format "kfx-continuous-model"; docs/formats.md, "Continuous-time model
// files"): the Kalman-Bucy setting of paper 003 (include/kfx/continuous.hpp),
//   dz = A z dt + B du,   dy = C z dt + dw,   z(0) ~ N(m0, P0),   Cov du = Q dt,  Cov dw = R dt,
// and the sampling step dt of its data: the measurements are the increments y(t_k) - y(t_{k-1}) on the
// grid t_k = k dt. Read as a discrete model, the file is the exact discrete-time equivalent at that grid
// (SampledModel: the state x_k = [z(t_k); int_{t_{k-1}}^{t_k} z ds], dimension 2p).
#include <string>

#include "kfx/continuous.hpp"
#include "kfx/model.hpp"

namespace kfx {

struct ContinuousModelFile {
  ContinuousModel model;
  double dt = 0.0;  ///< sampling step of the data (> 0)
};

/// The file's "format" field: true when it is "kfx-continuous-model" (false for any other file,
/// including one that is not a regular file or cannot be read or parsed: the reader of that format
/// reports it).
bool IsContinuousModelFile(const std::string& path);

/// Reads a continuous-time model file.
/// @throws kfx::Error naming the file and the field ("FILE: field 'dt': expected a finite number > 0,
///         got ...", "FILE: field 'R': expected a positive definite matrix ...").
ContinuousModelFile LoadContinuousModel(const std::string& path);

/// The exact discrete-time equivalent of `file` at its grid: the time-invariant Model whose step is
/// SampledModel(model, dt, 1)'s (any number of steps).
Model SampledAtFileGrid(const ContinuousModelFile& file);

/// A model file (LoadModel) or a continuous-time model file read as SampledAtFileGrid: what `kfx filter`
/// and `kfx simulate` read. (LoadModel itself reads "kfx-model" files only.)
/// @throws kfx::Error naming the file and the field.
Model LoadModelOrSampled(const std::string& path);

}  // namespace kfx
