// Resolving a method specification against the true model (include/kfx/compare.hpp): the dispatch by
// method name, the helpers the resolvers share (resolve_internal.hpp), and reading the true model.
#include "compare/resolve_internal.hpp"
#include "kfx/coupled_model_file.hpp"
#include "kfx/error.hpp"
#include "kfx/io.hpp"
#include "kfx/validation.hpp"

namespace kfx {

namespace detail {

std::string Where(const MethodSpec& spec) { return "method '" + spec.text + "': "; }

Eigen::MatrixXd ReadMatrixParameter(const MethodSpec& spec, const std::string& key) {
  const std::string path = spec.Get(key);
  try {
    if (path.size() >= 4 && path.compare(path.size() - 4, 4, ".csv") == 0) {
      const TimeSeries t = ReadTimeSeries(path);
      if (!t.allFinite()) throw Error(path + ": expected finite entries");
      return Eigen::MatrixXd(t);
    }
    return ReadNpyMatrix(path);
  } catch (const Error& e) {
    throw Error(Where(spec) + key + ": " + e.what());
  }
}

double LinearFilterBytes(const LinearFilter& filter) {
  const double nz = static_cast<double>(filter.state_dim()), m = static_cast<double>(filter.meas_dim());
  const LinearFilterStepPtr s = filter.step(1);
  const double per_step = static_cast<double>(s->Phi.size() + s->K.size() + s->O.size());
  const double steps = filter.time_invariant() ? 1.0 : static_cast<double>(filter.horizon());
  return 8.0 * (steps * per_step + nz + m);
}

void RequireTimeInvariant(const MethodSpec& spec, const Model& model) {
  if (!model.time_invariant()) {
    throw Error(Where(spec) + spec.name + " needs a time-invariant model, got a time-varying one");
  }
}

}  // namespace detail

ComparisonModel LoadComparisonModel(const std::string& path) {
  const std::string format = JsonFileFormat(path);
  if (format == "kfx-continuous-model") {
    ContinuousModelFile file = LoadContinuousModel(path);
    Model sampled = SampledAtFileGrid(file);
    return ComparisonModel{std::move(sampled), std::nullopt, std::move(file)};
  }
  if (format == "kfx-coupled-model") {
    const CoupledModelHeader header = ReadCoupledModelHeader(path);
    CoupledSystem system = LoadCoupledModelSlice(path, 0, header.n);
    Model dense = ToDenseModel(system);
    return ComparisonModel{std::move(dense), std::move(system), std::nullopt};
  }
  return ComparisonModel{LoadModel(path), std::nullopt, std::nullopt};
}

ResolvedMethod ResolveMethod(const MethodSpec& spec, const ComparisonModel& truth, const MethodOptions& options) {
  if (options.steps < 1) throw Error("steps: expected at least 1, got " + std::to_string(options.steps));
  // A spec is checked as the parser checks text (one built by hand, too).
  const MethodSpec checked = ParseMethodSpec(spec.text);
  const std::string& n = checked.name;
  const detail::Stopwatch clock;
  ResolvedMethod r = (n == "tau" || n == "mu" || n == "subspace" || n == "subspace61")
                         ? detail::ResolveProjection(checked, truth, options)
                     : n == "sampled" ? detail::ResolveSampled(checked, truth, options)
                                      : detail::ResolveKalmanFamily(checked, truth, options);
  r.offline_seconds = clock.Seconds();
  r.spec = checked;
  if (!r.run) {
    std::shared_ptr<const LinearFilter> filter = r.filter;
    r.run = [filter](const TimeSeries& y) { return RunLinearFilter(*filter, y); };
    r.online = "RunLinearFilter";
  }
  return r;
}

}  // namespace kfx
