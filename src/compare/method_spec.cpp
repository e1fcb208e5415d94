// The method-specification grammar (include/kfx/method_spec.hpp): the table of methods and their
// parameters, and the parser.
#include "kfx/method_spec.hpp"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <map>

#include "kfx/enum_text.hpp"
#include "kfx/error.hpp"

namespace kfx {

namespace {

struct MethodTable {
  std::vector<std::string> params;  // the first one positional when `positional`
  bool positional = false;
  std::vector<std::string> required;  // parameters that must be given
};

const std::map<std::string, MethodTable>& Table() {
  static const std::map<std::string, MethodTable> table = {
      {"kalman", {{"form"}, true, {}}},
      {"steady", {{}, false, {}}},
      {"design", {{"model", "gain"}, true, {"model"}}},
      {"coarse", {{"model", "prolongation"}, false, {"model", "prolongation"}}},
      {"tau", {{"order", "step", "modes", "basis", "weight"}, false, {}}},
      {"mu", {{"order", "step", "modes", "basis"}, false, {}}},
      {"subspace", {{"basis", "gram", "gain", "mesh"}, false, {}}},
      {"subspace61", {{"basis", "gram", "mesh"}, false, {}}},
      {"sampled", {{"dt", "gain"}, true, {"dt"}}},
      {"blockdiag", {{}, false, {}}},
      {"banded", {{}, false, {}}},
  };
  return table;
}

bool Contains(const std::vector<std::string>& names, const std::string& text) {
  return std::find(names.begin(), names.end(), text) != names.end();
}

std::string Quoted(const std::vector<std::string>& names) {
  std::string s;
  for (const std::string& n : names) s += (s.empty() ? "'" : ", '") + n + "'";
  return s;
}

// The values a choice parameter accepts (empty: any value).
std::vector<std::string> Choices(const std::string& method, const std::string& key) {
  if (key == "form") return KalmanFormNames();
  if (key == "step") return {"one", "two-da", "two-forecast"};
  if (key == "modes") return {"least-damped"};
  if (key == "gain" && method == "design") return {"steady", "schedule"};
  if (key == "gain" && method == "subspace") return {"schedule", "converged"};
  if (key == "gain" && method == "sampled") return {"schedule", "steady"};
  return {};
}

}  // namespace

std::vector<std::string> KalmanFormNames() {
  std::vector<std::string> names = EnumNames<CovarianceUpdateForm>();  // the conventional form's updates
  for (const std::string& name : EnumNames<FilterForm>()) {
    if (name != ToString(FilterForm::kConventional)) names.push_back(name);
  }
  return names;
}

KalmanFilterOptions ParseKalmanForm(const std::string& argument, const std::string& text) {
  const std::vector<std::string> names = KalmanFormNames();
  if (!Contains(names, text)) {
    throw Error(argument + ": expected one of " + Quoted(names) + ", got '" + text + "'");
  }
  KalmanFilterOptions options;
  if (Contains(EnumNames<CovarianceUpdateForm>(), text)) {
    options.form = FilterForm::kConventional;
    options.update_form = ParseEnum<CovarianceUpdateForm>(argument, text);
  } else {
    options.form = ParseEnum<FilterForm>(argument, text);
  }
  return options;
}

bool MethodSpec::Has(const std::string& key) const {
  return std::any_of(params.begin(), params.end(), [&](const auto& p) { return p.first == key; });
}

std::string MethodSpec::Get(const std::string& key, const std::string& fallback) const {
  for (const auto& p : params)
    if (p.first == key) return p.second;
  return fallback;
}

long MethodSpec::GetPositive(const std::string& key, long fallback) const {
  if (!Has(key)) return fallback;
  const std::string v = Get(key);
  errno = 0;
  char* end = nullptr;
  const long value = std::strtol(v.c_str(), &end, 10);
  if (v.empty() || *end != '\0' || errno == ERANGE || value < 1 || v.find_first_not_of("0123456789") != v.npos) {
    throw Error("method '" + text + "': " + key + ": expected a positive integer, got '" + v + "'");
  }
  return value;
}

double MethodSpec::GetPositiveNumber(const std::string& key) const {
  const std::string v = Get(key);
  errno = 0;
  char* end = nullptr;
  const double value = std::strtod(v.c_str(), &end);
  if (v.empty() || *end != '\0' || errno == ERANGE || !std::isfinite(value) || !(value > 0)) {
    throw Error("method '" + text + "': " + key + ": expected a finite number > 0, got '" + v + "'");
  }
  return value;
}

const std::vector<std::string>& MethodNames() {
  static const std::vector<std::string> names = {"kalman",   "steady",     "design",  "coarse",    "tau",   "mu",
                                                 "subspace", "subspace61", "sampled", "blockdiag", "banded"};
  return names;
}

const std::vector<std::string>& MethodParameters(const std::string& method) {
  const auto it = Table().find(method);
  if (it == Table().end()) throw Error("method '" + method + "': unknown method");
  return it->second.params;
}

MethodSpec ParseMethodSpec(const std::string& text) {
  const std::string where = "method '" + text + "': ";
  MethodSpec spec;
  spec.text = text;
  const std::size_t colon = text.find(':');
  spec.name = text.substr(0, colon);
  if (spec.name.empty()) {
    throw Error(where + "expected NAME[:KEY=VALUE,...] with NAME one of " + Quoted(MethodNames()));
  }
  const auto it = Table().find(spec.name);
  if (it == Table().end()) {
    throw Error(where + "unknown method '" + spec.name + "', expected one of " + Quoted(MethodNames()));
  }
  const MethodTable& table = it->second;
  if (colon != std::string::npos) {
    const std::string rest = text.substr(colon + 1);
    std::size_t start = 0;
    for (int index = 0;; ++index) {
      const std::size_t comma = rest.find(',', start);
      const std::string item = rest.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
      const std::size_t eq = item.find('=');
      std::string key, value;
      if (eq == std::string::npos) {
        if (index != 0 || !table.positional || item.empty()) {
          throw Error(where + "expected KEY=VALUE, got '" + item + "'" +
                      (table.params.empty() ? " (" + spec.name + " takes no parameters)"
                                            : " (" + spec.name + " takes " + Quoted(table.params) + ")"));
        }
        key = table.params.front();
        value = item;
      } else {
        key = item.substr(0, eq);
        value = item.substr(eq + 1);
      }
      if (!Contains(table.params, key)) {
        throw Error(where + "unknown parameter '" + key + "' of " + spec.name +
                    (table.params.empty() ? " (it takes none)" : " (it takes " + Quoted(table.params) + ")"));
      }
      if (value.empty()) throw Error(where + key + ": expected a value, got nothing");
      if (spec.Has(key)) throw Error(where + key + ": given twice");
      const std::vector<std::string> choices = Choices(spec.name, key);
      if (!choices.empty() && !Contains(choices, value)) {
        throw Error(where + key + ": expected one of " + Quoted(choices) + ", got '" + value + "'");
      }
      spec.params.emplace_back(key, value);
      if (comma == std::string::npos) break;
      start = comma + 1;
    }
  }
  for (const std::string& key : table.required) {
    if (!spec.Has(key)) throw Error(where + spec.name + " needs " + key + "=...");
  }
  if ((spec.name == "tau" || spec.name == "mu") && !spec.Has("order") && !spec.Has("basis") && !spec.Has("weight")) {
    throw Error(where + spec.name + " needs order=N (or basis=FILE" + (spec.name == "tau" ? ", weight=FILE)" : ")"));
  }
  if (spec.Has("order")) spec.GetPositive("order", 0);
  if ((spec.name == "subspace" || spec.name == "subspace61") && spec.Has("basis") == spec.Has("mesh")) {
    throw Error(where + spec.name + " needs basis=FILE or mesh=N (one of them)");
  }
  if (spec.Has("mesh")) spec.GetPositive("mesh", 0);
  if (spec.Has("dt")) spec.GetPositiveNumber("dt");
  return spec;
}

}  // namespace kfx
