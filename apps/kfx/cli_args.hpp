#pragma once
// The kfx command line: argument structs and the parser (CLI11). Kept apart from main.cpp so that
// the argument handling can be fuzzed without the library (fuzz/fuzz_cli.cpp).
#include <cstdint>
#include <string>
#include <vector>

namespace kfx::cli {

struct SimulateArgs {
  std::string model, out;
  int steps = 100;
  std::uint64_t seed = 1;
  bool csv = false;
  std::string input;  ///< known input g (T, q) as .npy or .csv; empty: none (issue 22)
};

struct FilterArgs {
  std::string model, data, out;
  std::string input;  ///< known input g (T, q) as .npy or .csv; empty: none (issue 22)
  bool csv = false;
  std::string form = "joseph";  ///< one of FilterFormChoices()
  bool health = false;          ///< full health checks: also every P_{k|k}'s eigenvalues
  bool no_health = false;       ///< no health checks (the cheap ones are on by default)
  std::string method;           ///< filter only: a method specification (docs/cli.md); empty = the Kalman filter
};

struct CompareArgs {
  std::string model, weight, json, out;
  std::vector<std::string> methods;  ///< method specifications (docs/cli.md)
  int steps = 100;
  bool stationary = false;
  int monte_carlo = 0;
  std::uint64_t seed = 1;
};

struct AnalyzeArgs {
  std::string model, design, json, input;
  int monte_carlo = 0;
  int steps = 50;
  std::uint64_t seed = 1;
};

struct MismatchArgs {
  std::string model, ranges, json;
  bool no_refine = false;
};

struct ReproduceArgs {
  std::string paper, json, out;
  bool quick = false;
  bool brief = false;  ///< a short summary per paper (the full tables go to --out DIR/<paper>/table.txt)
};

struct BlockDiagArgs {
  std::string model, data, out, filter = "block-diagonal";  ///< filter: one of BlockDiagFilterChoices()
  long granule = 1024;
  int steps = -1;
  double steady_state_tolerance = 0.0;  ///< 0: off
};

struct InfoArgs {
  bool json = false;     ///< print JSON instead of "key: value" lines
  double seconds = 0.2;  ///< time spent measuring the DGEMM rate
};

struct CommandLine {
  std::string command;  ///< the subcommand given
  SimulateArgs sim;
  FilterArgs flt, smo;
  AnalyzeArgs ana;
  MismatchArgs mis;
  ReproduceArgs rep;
  BlockDiagArgs bd;
  InfoArgs info;
  CompareArgs cmp;
};

/// The values of `--form` (filter, smooth): joseph, standard, sqrt, ud, information. Listed here, not derived
/// from the library's enum names, so that this file needs no library; tests/cli/cli_options_test.cpp checks
/// them against kfx::cli::FilterFormNames() (filter_form.hpp).
const std::vector<std::string>& FilterFormChoices();
/// The values of `blockdiag --filter`: block-diagonal, banded, the names (ToString) of the two
/// kfx::CoupledFilterKind values the distributed job runs (checked by the same test).
const std::vector<std::string>& BlockDiagFilterChoices();

/// The one rule for every integer option: `text` is a whole number in [lo, hi] written in decimal digits (a leading
/// '-' only if lo < 0); sets *value (two's complement for a negative one) and returns true, else returns false.
/// Used by the parser for --steps, --seed, --monte-carlo, --granule (and any later integer option).
bool ParseIntegerOption(const std::string& text, long long lo, unsigned long long hi, unsigned long long* value);

/// The parser of the kfx command line (CLI11), built once and reusable: each Parse() starts from
/// the default arguments.
class CommandLineParser {
 public:
  /// `papers`: the accepted arguments of `reproduce`.
  explicit CommandLineParser(const std::vector<std::string>& papers);
  ~CommandLineParser();
  CommandLineParser(const CommandLineParser&) = delete;
  CommandLineParser& operator=(const CommandLineParser&) = delete;
  /// Parses argv into *out. Returns -1 when out->command is to be run, otherwise the exit code:
  /// 0 after --help / --version (printed on stdout), 2 after a usage error (one line on stderr).
  int Parse(int argc, const char* const* argv, CommandLine* out);

 private:
  struct Impl;
  Impl* impl_;
};

}  // namespace kfx::cli
