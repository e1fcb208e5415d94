// The CLI's option values that name library enums: apps/kfx/cli_args.cpp lists them literally (so that the
// parser, fuzzed alone by fuzz/fuzz_cli.cpp, needs no library); here they are checked against the library's
// enum names (ToString / EnumNames), and each one is parsed with kfx::ParseEnum into the value it names.
#include <gtest/gtest.h>

#include <algorithm>
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

// Every integer option (the list is literal, as in cli_args.cpp): in-range values are taken exactly; negative,
// out-of-range, wrapped, fractional or exponent values are a usage error (CLI11 alone turned --seed -1 into
// 2^64 - 1 and --seed 18446744073709551616 into 2^64 - 1).
TEST(CliOptions, EveryIntegerOptionRejectsWhatItCannotHoldExactly) {
  struct Option {
    std::vector<std::string> command;
    std::string name, lowest, highest, below, above;
  };
  const std::vector<std::string> sim = {"simulate", "m.json", "-o", "out"};
  const std::vector<std::string> ana = {"analyze", "m.json"};
  const std::vector<std::string> bd = {"blockdiag", "m.json", "--data", "y.npy", "-o", "out"};
  const std::vector<std::string> cmp = {"compare", "m.json", "-m", "kalman"};
  const Option options[] = {
      {sim, "--steps", "0", "2000000000", "-1", "2000000001"},
      {sim, "--seed", "0", "18446744073709551615", "-1", "18446744073709551616"},
      {ana, "--steps", "1", "2000000000", "0", "2000000001"},
      {ana, "--monte-carlo", "0", "2000000000", "-1", "2000000001"},
      {ana, "--seed", "0", "18446744073709551615", "-5", "99999999999999999999999"},
      {bd, "--granule", "1", "1000000000", "0", "1000000001"},
      {bd, "--steps", "0", "2000000000", "-1", "4294967296"},
      {cmp, "--steps", "1", "2000000000", "0", "2000000001"},
      {cmp, "--monte-carlo", "0", "2000000000", "-1", "2000000001"},
      {cmp, "--seed", "0", "18446744073709551615", "-1", "18446744073709551616"},
  };
  CommandLine cl;
  for (const Option& o : options) {
    for (const std::string& good : {o.lowest, o.highest}) {
      std::vector<std::string> args = o.command;
      args.insert(args.end(), {o.name, good});
      ASSERT_EQ(ParseArgs(args, &cl), -1) << o.name << " " << good;
      unsigned long long got = 0;
      const std::string& cmd = o.command[0];
      if (cmd == "simulate") got = o.name == "--seed" ? cl.sim.seed : static_cast<unsigned long long>(cl.sim.steps);
      if (cmd == "analyze") {
        got = o.name == "--seed"    ? cl.ana.seed
              : o.name == "--steps" ? static_cast<unsigned long long>(cl.ana.steps)
                                    : static_cast<unsigned long long>(cl.ana.monte_carlo);
      }
      if (cmd == "compare") {
        got = o.name == "--seed"    ? cl.cmp.seed
              : o.name == "--steps" ? static_cast<unsigned long long>(cl.cmp.steps)
                                    : static_cast<unsigned long long>(cl.cmp.monte_carlo);
      }
      if (cmd == "blockdiag") {
        got = o.name == "--granule" ? static_cast<unsigned long long>(cl.bd.granule)
                                    : static_cast<unsigned long long>(cl.bd.steps);
      }
      EXPECT_EQ(std::to_string(got), good) << cmd << " " << o.name;
    }
    for (const std::string& bad :
         {o.below, o.above, std::string("1e3"), std::string("2.0"), std::string("0x10"), std::string(" 7"),
          std::string("7 "), std::string("+7"), std::string(""), std::string("-0x1"), std::string("nan")}) {
      std::vector<std::string> args = o.command;
      args.insert(args.end(), {o.name, bad});
      ::testing::internal::CaptureStderr();
      EXPECT_EQ(ParseArgs(args, &cl), 2) << o.command[0] << " " << o.name << " '" << bad << "'";
      const std::string err = ::testing::internal::GetCapturedStderr();
      EXPECT_NE(err.find(o.name), std::string::npos) << err;
      EXPECT_EQ(std::count(err.begin(), err.end(), '\n'), 1) << err;
    }
  }
}

TEST(CliOptions, IntegerRuleIsExactAtTheLimitsOfItsRange) {
  unsigned long long v = 7;
  EXPECT_TRUE(ParseIntegerOption("-9223372036854775808", -9223372036854775807LL - 1, 0, &v));
  EXPECT_EQ(static_cast<long long>(v), -9223372036854775807LL - 1);
  EXPECT_FALSE(ParseIntegerOption("-9223372036854775809", -9223372036854775807LL - 1, 0, &v));
  EXPECT_TRUE(ParseIntegerOption("-3", -3, 5, &v));
  EXPECT_EQ(static_cast<long long>(v), -3);
  EXPECT_FALSE(ParseIntegerOption("-4", -3, 5, &v));
  EXPECT_TRUE(ParseIntegerOption("-0", 0, 5, &v));
  EXPECT_EQ(v, 0u);
  EXPECT_TRUE(ParseIntegerOption("000000000000000000000005", 0, 5, &v) == false);  // more digits than any uint64
  EXPECT_TRUE(ParseIntegerOption("0005", 0, 5, &v));
  EXPECT_EQ(v, 5u);
}

}  // namespace
}  // namespace kfx::cli
