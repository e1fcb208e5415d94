#pragma once
// What the method resolvers (resolve_kalman.cpp, resolve_projection.cpp) share: the error prefix, file
// parameters, timing and the memory count of a LinearFilter.
#include <Eigen/Dense>
#include <chrono>
#include <string>

#include "kfx/compare.hpp"

namespace kfx::detail {

/// "method 'SPEC': ".
std::string Where(const MethodSpec& spec);
/// The matrix in the file named by parameter `key` (.npy, or .csv: one row per line).
/// @throws kfx::Error "method 'SPEC': KEY: <the reader's message>".
Eigen::MatrixXd ReadMatrixParameter(const MethodSpec& spec, const std::string& key);
/// Bytes of the matrices the online recursion of `filter` applies (all steps of a time-varying one) and
/// of its state.
double LinearFilterBytes(const LinearFilter& filter);
/// @throws kfx::Error "method 'SPEC': needs a time-invariant model" unless it is.
void RequireTimeInvariant(const MethodSpec& spec, const Model& model);

ResolvedMethod ResolveKalmanFamily(const MethodSpec& spec, const ComparisonModel& truth, const MethodOptions& options);
ResolvedMethod ResolveProjection(const MethodSpec& spec, const ComparisonModel& truth, const MethodOptions& options);
ResolvedMethod ResolveSampled(const MethodSpec& spec, const ComparisonModel& truth, const MethodOptions& options);

class Stopwatch {
 public:
  double Seconds() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count(); }

 private:
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

}  // namespace kfx::detail
