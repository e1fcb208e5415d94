// The --form option of `kfx filter` and `kfx smooth`: its vocabulary and its parsing with kfx::ParseEnum.
#include "filter_form.hpp"

#include "kfx/method_spec.hpp"

namespace kfx::cli {

// One vocabulary with the method specifications' `kalman:form=...` (kfx/method_spec.hpp).
std::vector<std::string> FilterFormNames() { return KalmanFormNames(); }

KalmanFilterOptions ParseFilterForm(const std::string& text) { return ParseKalmanForm("--form", text); }

}  // namespace kfx::cli
