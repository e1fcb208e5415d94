// The --form option of `kfx filter` and `kfx smooth`: its vocabulary and its parsing with kfx::ParseEnum.
#include "filter_form.hpp"

#include <algorithm>

#include "kfx/enum_text.hpp"

namespace kfx::cli {

namespace {

bool Contains(const std::vector<std::string>& names, const std::string& text) {
  return std::find(names.begin(), names.end(), text) != names.end();
}

}  // namespace

std::vector<std::string> FilterFormNames() {
  std::vector<std::string> names = EnumNames<CovarianceUpdateForm>();  // the conventional form's updates
  for (const std::string& name : EnumNames<FilterForm>()) {
    if (name != ToString(FilterForm::kConventional)) names.push_back(name);
  }
  return names;
}

KalmanFilterOptions ParseFilterForm(const std::string& text) {
  const std::vector<std::string> names = FilterFormNames();
  if (!Contains(names, text)) {
    std::string expected;
    for (const std::string& name : names) expected += (expected.empty() ? "'" : ", '") + name + "'";
    throw Error("--form: expected one of " + expected + ", got '" + text + "'");
  }
  KalmanFilterOptions options;
  if (Contains(EnumNames<CovarianceUpdateForm>(), text)) {
    options.form = FilterForm::kConventional;
    options.update_form = ParseEnum<CovarianceUpdateForm>("--form", text);
  } else {
    options.form = ParseEnum<FilterForm>("--form", text);
  }
  return options;
}

}  // namespace kfx::cli
