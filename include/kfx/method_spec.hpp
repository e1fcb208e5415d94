#pragma once
// Method specifications: one small grammar that names any filter kfx has, with its parameters, shared
// by the CLI (`kfx filter --method`, `kfx compare --method`), JSON and Python (docs/cli.md, "Method
// specifications"):
//
//   spec   := NAME [ ':' param { ',' param } ]
//   param  := KEY '=' VALUE | VALUE          (a bare VALUE is the method's positional parameter)
//
// e.g. `kalman`, `kalman:form=sqrt`, `steady`, `design:low_q.json`, `tau:order=4,step=two-da`,
// `mu:order=2,modes=least-damped`, `subspace:basis=E.npy,gram=W.npy`, `subspace61:basis=E.npy`,
// `subspace:mesh=3`, `coarse:model=coarse.json,prolongation=E.npy`, `sampled:dt=0.1`, `blockdiag`,
// `banded`. Parsing checks the grammar,
// the method's name, its parameter names and the values that need no model (integers, choices);
// ResolveMethod (compare.hpp) checks the rest against the model.
#include <string>
#include <utility>
#include <vector>

#include "kfx/kalman_filter.hpp"

namespace kfx {

struct MethodSpec {
  std::string text;  ///< the specification as given (every error message names it)
  std::string name;  ///< one of MethodNames()
  /// The parameters in the order given, a positional value under its key.
  std::vector<std::pair<std::string, std::string>> params;

  bool Has(const std::string& key) const;
  /// The value of `key`, or `fallback` when it is not given.
  std::string Get(const std::string& key, const std::string& fallback = "") const;
  /// The value of `key` as a positive integer (fallback when not given).
  /// @throws kfx::Error "method 'SPEC': KEY: expected a positive integer, got 'VALUE'".
  long GetPositive(const std::string& key, long fallback) const;
  /// The value of `key` (which must be given) as a finite number > 0.
  /// @throws kfx::Error "method 'SPEC': KEY: expected a finite number > 0, got 'VALUE'".
  double GetPositiveNumber(const std::string& key) const;
};

/// The method names the grammar accepts: kalman, steady, design, coarse, tau, mu, subspace,
/// subspace61, sampled, blockdiag, banded.
const std::vector<std::string>& MethodNames();

/// The parameter names `method` takes (the first one is positional when the method has one).
/// @throws kfx::Error for an unknown method.
const std::vector<std::string>& MethodParameters(const std::string& method);

/// The names of the Kalman filter's forms: the conventional form by its covariance update ("joseph",
/// "standard": CovarianceUpdateForm), the others by their FilterForm name ("sqrt", "ud", "information").
/// `kalman:form=...` and the CLI's --form take these.
std::vector<std::string> KalmanFormNames();

/// The filter options the form `text` selects (the other options at their defaults).
/// @throws kfx::Error "ARGUMENT: expected one of 'joseph', ..., got 'TEXT'".
KalmanFilterOptions ParseKalmanForm(const std::string& argument, const std::string& text);

/// Parses one specification.
/// @throws kfx::Error "method 'TEXT': ..." for an empty text, an unknown method, an unknown, repeated
///         or missing parameter, a parameter without a value, or a value outside its choices.
MethodSpec ParseMethodSpec(const std::string& text);

}  // namespace kfx
