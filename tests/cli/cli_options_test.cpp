// The CLI's option values that name library enums: apps/kfx/cli_args.cpp lists them literally (so that the
// parser, fuzzed alone by fuzz/fuzz_cli.cpp, needs no library); here they are checked against the library's
// enum names (ToString / EnumNames), and each one is parsed with kfx::ParseEnum into the value it names.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "cli_args.hpp"
#include "filter_form.hpp"
#include "kfx/block_diagonal.hpp"
#include "kfx/enum_text.hpp"
#include "kfx/kalman_filter.hpp"
#include "support/expect_error.hpp"

namespace kfx::cli {
namespace {

using kfx::testing::ThrowsErrorStartingWith;

// Parses `kfx ARGS...`; returns Parse's code.
int ParseArgs(const std::vector<std::string>& args, CommandLine* out) {
  static CommandLineParser parser({"patel-toda", "all"});
  std::vector<const char*> argv{"kfx"};
  for (const std::string& a : args) argv.push_back(a.c_str());
  return parser.Parse(static_cast<int>(argv.size()), argv.data(), out);
}

TEST(CliOptions, FormChoicesAreTheLibraryNames) {
  EXPECT_EQ(FilterFormChoices(), FilterFormNames());
  EXPECT_EQ(FilterFormChoices(), (std::vector<std::string>{"joseph", "standard", "sqrt", "ud", "information"}));
}

TEST(CliOptions, EachFormSelectsTheFormItNames) {
  struct Case {
    const char* text;
    FilterForm form;
    CovarianceUpdateForm update_form;
  };
  const Case cases[] = {{"joseph", FilterForm::kConventional, CovarianceUpdateForm::kJoseph},
                        {"standard", FilterForm::kConventional, CovarianceUpdateForm::kStandard},
                        {"sqrt", FilterForm::kSquareRoot, CovarianceUpdateForm::kJoseph},
                        {"ud", FilterForm::kUD, CovarianceUpdateForm::kJoseph},
                        {"information", FilterForm::kInformation, CovarianceUpdateForm::kJoseph}};
  for (const Case& c : cases) {
    const KalmanFilterOptions options = ParseFilterForm(c.text);
    EXPECT_EQ(options.form, c.form) << c.text;
    EXPECT_EQ(options.update_form, c.update_form) << c.text;
    EXPECT_TRUE(options.symmetrize) << c.text;  // the other options keep their defaults
  }
  EXPECT_EQ(std::string(FilterArgs().form), ToString(KalmanFilterOptions().update_form));  // the default form
}

TEST(CliOptions, FormRejectsOtherTexts) {
  for (const std::string text : {"conventional", "Joseph", "square-root", ""}) {
    EXPECT_TRUE(ThrowsErrorStartingWith([&] { ParseFilterForm(text); }, "--form: expected one of",
                                        {"'joseph', 'standard', 'sqrt', 'ud', 'information'", "'" + text + "'"}));
  }
}

TEST(CliOptions, BlockDiagFilterChoicesAreTheDistributedKinds) {
  const std::vector<std::string> distributed = {ToString(CoupledFilterKind::kBlockDiagonal),
                                                ToString(CoupledFilterKind::kBanded)};
  EXPECT_EQ(BlockDiagFilterChoices(), distributed);
  for (const std::string& text : BlockDiagFilterChoices()) {
    EXPECT_EQ(ToString(ParseEnum<CoupledFilterKind>("--filter", text)), text);
  }
  EXPECT_EQ(BlockDiagArgs().filter, ToString(CoupledFilterKind::kBlockDiagonal));  // the default kind
}

TEST(CliOptions, ParserAcceptsExactlyTheChoices) {
  CommandLine cl;
  for (const std::string& form : FilterFormChoices()) {
    ASSERT_EQ(ParseArgs({"smooth", "m.json", "--data", "y.npy", "-o", "out", "--form", form}, &cl), -1) << form;
    EXPECT_EQ(cl.smo.form, form);
  }
  for (const std::string& filter : BlockDiagFilterChoices()) {
    ASSERT_EQ(ParseArgs({"blockdiag", "m.json", "--data", "y.npy", "-o", "out", "--filter", filter}, &cl), -1);
    EXPECT_EQ(cl.bd.filter, filter);
  }
  ASSERT_EQ(ParseArgs({"info", "--json", "--seconds", "0.05"}, &cl), -1);
  EXPECT_EQ(cl.command, "info");
  EXPECT_TRUE(cl.info.json);
  EXPECT_EQ(cl.info.seconds, 0.05);
  EXPECT_EQ(ParseArgs({"info", "--seconds", "0"}, &cl), 2);
  // Names of the library that the options do not take (a usage error: one line on stderr, exit code 2).
  EXPECT_EQ(ParseArgs({"filter", "m.json", "--data", "y.npy", "-o", "out", "--form", "conventional"}, &cl), 2);
  EXPECT_EQ(ParseArgs({"blockdiag", "m.json", "--data", "y.npy", "-o", "out", "--filter", "full"}, &cl), 2);
}

}  // namespace
}  // namespace kfx::cli
