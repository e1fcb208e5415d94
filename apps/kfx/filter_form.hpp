#pragma once
// The --form option of `kfx filter` and `kfx smooth`: its vocabulary and its parsing with kfx::ParseEnum.
// The conventional form is named by its covariance update ("joseph", "standard": CovarianceUpdateForm),
// the others by their FilterForm name ("sqrt", "ud", "information").
#include <string>
#include <vector>

#include "kfx/kalman_filter.hpp"

namespace kfx::cli {

/// The texts --form accepts, from the library's enum names: "joseph", "standard", "sqrt", "ud",
/// "information" (cli_args.cpp lists them literally; tests/cli/cli_options_test.cpp checks they agree).
std::vector<std::string> FilterFormNames();

/// The filter options --form `text` selects (the other options at their defaults).
/// @throws kfx::Error "--form: expected one of 'joseph', ..., got '<text>'".
KalmanFilterOptions ParseFilterForm(const std::string& text);

}  // namespace kfx::cli
