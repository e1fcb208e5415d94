// The kfx command line parsed with CLI11 into the argument structs of cli_args.hpp; free of the library
// (its headers and its link), so that fuzz/fuzz_cli.cpp can compile this file alone.
#include "cli_args.hpp"

#include <CLI/CLI.hpp>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <type_traits>

#ifndef KFX_VERSION
#define KFX_VERSION "unknown"
#endif

namespace kfx::cli {

const std::vector<std::string>& FilterFormChoices() {
  static const std::vector<std::string> choices = {"joseph", "standard", "sqrt", "ud", "information"};
  return choices;
}

const std::vector<std::string>& BlockDiagFilterChoices() {
  static const std::vector<std::string> choices = {"block-diagonal", "banded"};
  return choices;
}

bool ParseIntegerOption(const std::string& text, long long lo, unsigned long long hi, unsigned long long* value) {
  // Digits only (an optional leading '-' only when lo < 0): CLI11's own conversion wraps "-1" to 2^64 - 1 for an
  // unsigned option and takes "1e3" or " 7" as it can.
  const bool negative = !text.empty() && text[0] == '-';
  const std::string digits = negative ? text.substr(1) : text;
  if (digits.empty() || digits.size() > 20 || digits.find_first_not_of("0123456789") != std::string::npos) return false;
  errno = 0;
  const unsigned long long magnitude = std::strtoull(digits.c_str(), nullptr, 10);
  if (errno == ERANGE) return false;
  if (negative) {
    if (magnitude == 0) {
      *value = 0;
      return lo <= 0;
    }
    if (lo >= 0 || magnitude > static_cast<unsigned long long>(-(lo + 1)) + 1) return false;
    *value = static_cast<unsigned long long>(-static_cast<long long>(magnitude - 1) - 1);  // two's complement
    return true;
  }
  if (magnitude > hi || (lo > 0 && magnitude < static_cast<unsigned long long>(lo))) return false;
  *value = magnitude;
  return true;
}

namespace {

// Every integer option of kfx goes through here: a whole number in [lo, hi] or a usage error naming the option
// and the range (no wrap-around, no silent clamping, no exponent or fraction).
template <typename T>
CLI::Option* AddIntegerOption(CLI::App* app, const std::string& names, T& target, long long lo, unsigned long long hi,
                              const std::string& help) {
  static_assert(std::is_integral<T>::value, "AddIntegerOption: integer targets only");
  CLI::Option* opt = app->add_option(names, help);
  opt->type_name("INT");
  opt->each([&target, lo, hi](const std::string& text) {
    unsigned long long v = 0;
    if (!ParseIntegerOption(text, lo, hi, &v)) {
      // CLI11 prefixes the option's name ("--seed: expected ...").
      throw CLI::ValidationError("expected a whole number in [" + std::to_string(lo) + ", " + std::to_string(hi) +
                                 "], got '" + text + "'");
    }
    target = text[0] == '-' ? static_cast<T>(static_cast<long long>(v)) : static_cast<T>(v);
  });
  return opt;
}

constexpr unsigned long long kMaxInt = 2000000000ULL;
constexpr unsigned long long kMaxU64 = std::numeric_limits<std::uint64_t>::max();

// `kfx compare` (apps/kfx/compare.cpp).
void AddCompareCommand(CLI::App& app, CompareArgs& cmp) {
  auto* c = app.add_subcommand("compare", "Compare filters on one model: exact error, cost per step, memory");
  c->add_option("model", cmp.model, "True model file (model or coupled model, docs/formats.md)")->required();
  c->add_option("-m,--method", cmp.methods, "Method specification (docs/cli.md); repeat for each method")
      ->required()
      ->take_all();
  auto* steps = AddIntegerOption(c, "--steps", cmp.steps, 1, kMaxInt, "Horizon T of the exact MSE (default 100)");
  c->add_flag("--stationary", cmp.stationary, "Stationary MSE as the headline (kalman = its steady state)")
      ->excludes(steps);
  c->add_option("--weight", cmp.weight, "n x n weight W of the MSE tr(W E[e e^T]) (.npy or .csv)");
  AddIntegerOption(c, "--monte-carlo", cmp.monte_carlo, 0, kMaxInt,
                   "Also estimate the MSE by this many simulated runs");
  AddIntegerOption(c, "--seed", cmp.seed, 0, kMaxU64, "Seed of the timing run and the Monte Carlo runs");
  c->add_option("--json", cmp.json, "Write the rows as JSON");
  c->add_option("--out", cmp.out, "Directory for compare.json, the curves and the figures");
}

}  // namespace

struct CommandLineParser::Impl {
  CLI::App app{"kfx: Kalman filtering for large and infinite-dimensional linear systems"};
  CommandLine args;  // the options write here
};

CommandLineParser::~CommandLineParser() { delete impl_; }

CommandLineParser::CommandLineParser(const std::vector<std::string>& papers) : impl_(new Impl) {
  CLI::App& app = impl_->app;
  CommandLine* out = &impl_->args;
  app.set_version_flag("--version", std::string("kfx ") + KFX_VERSION);
  app.require_subcommand(1);

  SimulateArgs& sim = out->sim;
  auto* c_sim = app.add_subcommand("simulate", "Simulate states and measurements of a model");
  c_sim->add_option("model", sim.model, "Model file (JSON, docs/formats.md)")->required();
  AddIntegerOption(c_sim, "--steps", sim.steps, 0, kMaxInt, "Number of steps T");
  AddIntegerOption(c_sim, "--seed", sim.seed, 0, kMaxU64, "Random seed");
  c_sim->add_option("-o,--out", sim.out, "Output directory (x.npy: (T+1, n), y.npy: (T, m))")->required();
  c_sim->add_flag("--csv", sim.csv, "Write CSV instead of .npy");
  c_sim->add_option("--input", sim.input,
                    "Known input g (T, q) as .npy or .csv, row k-1 = g_k, for a model with fields G, D");

  auto add_filter = [&](const char* name, const char* help, FilterArgs& a) {
    auto* c = app.add_subcommand(name, help);
    c->add_option("model", a.model, "Model file")->required();
    c->add_option("--data", a.data, "Measurements (T, m) as .npy or .csv; NaN = missing")->required();
    c->add_option("-o,--out", a.out, "Output directory")->required();
    c->add_flag("--csv", a.csv, "Write CSV instead of .npy");
    c->add_option("--input", a.input,
                  "Known input g (T, q) as .npy or .csv, row k-1 = g_k, for a model with fields G, D");
    c->add_option("--form", a.form,
                  "Covariance form: joseph (default), standard, sqrt (square root), ud (Bierman-Thornton), "
                  "information (docs/robustness.md)")
        ->check(CLI::IsMember(FilterFormChoices()));
    auto* full = c->add_flag("--health", a.health,
                             "Full health checks: also the smallest eigenvalue of every P_{k|k} (the cheap checks, "
                             "Cholesky of P_{k|k} and the NIS, are on by default; summary.json \"health\")");
    c->add_flag("--no-health", a.no_health, "No health checks (no warning, no \"health\" in summary.json)")
        ->excludes(full);
    return c;
  };
  add_filter("filter", "Kalman filter: estimates, covariance diagonals, log-likelihood", out->flt)
      ->add_option("--method", out->flt.method,
                   "Run this method instead of the Kalman filter: a method specification (docs/cli.md), "
                   "e.g. steady, tau:order=4, blockdiag");
  add_filter("smooth", "Rauch-Tung-Striebel smoother", out->smo);

  AnalyzeArgs& ana = out->ana;
  auto* c_ana =
      app.add_subcommand("analyze",
                         "Steady state (DARE): covariances, both gains, closed-loop spectral radius, residual; "
                         "optionally exact vs Monte Carlo MSE");
  c_ana->add_option("model", ana.model, "True model file")->required();
  c_ana->add_option("--design", ana.design, "Design the filter on this model instead (mismatch study)");
  AddIntegerOption(c_ana, "--monte-carlo", ana.monte_carlo, 0, kMaxInt,
                   "Also compare exact and Monte Carlo MSE with this many runs");
  AddIntegerOption(c_ana, "--steps", ana.steps, 1, kMaxInt, "Horizon of the exact/Monte Carlo comparison");
  AddIntegerOption(c_ana, "--seed", ana.seed, 0, kMaxU64, "Monte Carlo seed");
  c_ana->add_option("--input", ana.input,
                    "Known input g (T, q) as .npy or .csv, row k-1 = g_k, driving MODEL (fields G, D) in the exact "
                    "and Monte Carlo comparison");
  c_ana->add_option("--json", ana.json, "Write the results as JSON");

  MismatchArgs& mis = out->mis;
  auto* c_mis = app.add_subcommand(
      "mismatch", "Robustness of a filter to model errors: worst case over error ranges and the Patel-Toda bounds");
  c_mis->add_option("model", mis.model, "Design model file (time-invariant)")->required();
  c_mis->add_option("--ranges", mis.ranges, "Element-wise error ranges (JSON, docs/formats.md)")->required();
  c_mis->add_option("--json", mis.json, "Write the results as JSON");
  c_mis->add_flag("--no-refine", mis.no_refine, "Corners only (no local refinement of the box search)");

  ReproduceArgs& rep = out->rep;
  auto* c_rep = app.add_subcommand("reproduce", "Put a paper's published numbers beside kfx's");
  c_rep
      ->add_option("paper", rep.paper,
                   "One of: aalto-spatial, bernstein, patel-toda, aalto-temporal, block-diagonal, all")
      ->required()
      ->check(CLI::IsMember(papers));
  c_rep->add_option("--json", rep.json, "Write the items as JSON");
  c_rep->add_option("--out", rep.out, "Directory for figures and data");
  c_rep->add_flag("--quick", rep.quick, "Small, fast versions of the computations");
  c_rep->add_flag("--brief", rep.brief,
                  "A short summary per paper instead of the full table (written to DIR/<paper>/table.txt with --out)");

  BlockDiagArgs& bd = out->bd;
  auto* c_bd = app.add_subcommand(
      "blockdiag", "Block-diagonal or banded filter of many coupled subsystems (mpirun -np N kfx blockdiag ...)");
  c_bd->add_option("model", bd.model, "Coupled model file (JSON, docs/formats.md \"Coupled model\")")->required();
  c_bd->add_option("--data", bd.data, "Measurements .npy of shape (T, n d); each rank reads its columns")->required();
  c_bd->add_option("-o,--out", bd.out, "Output directory: metadata.json, x_filt/P_filt per slice, coupling_*")
      ->required();
  c_bd->add_option("--filter", bd.filter, "block-diagonal (default) or banded")
      ->check(CLI::IsMember(BlockDiagFilterChoices()));
  AddIntegerOption(c_bd, "--granule", bd.granule, 1, 1000000000ULL, "Subsystems per partition unit (default 1024)");
  AddIntegerOption(c_bd, "--steps", bd.steps, 0, kMaxInt, "Number of steps (default: all rows of the data)");
  c_bd->add_option("--steady-state-tolerance", bd.steady_state_tolerance,
                   "Freeze the block-diagonal filter's gain once a step changes its covariance by at most this "
                   "(relative), then run the steady-state filter; 0 = off (default); one process only")
      ->check(CLI::Range(0.0, 1e-2));

  InfoArgs& info = out->info;
  auto* c_info = app.add_subcommand(
      "info", "The BLAS/LAPACK in use: libraries, versions, kernel against the CPU, threads, measured DGEMM rate");
  c_info->add_flag("--json", info.json, "Print JSON (the benchmarks read it)");
  c_info->add_option("--seconds", info.seconds, "Time spent measuring the DGEMM rate (default 0.2)")
      ->check(CLI::Range(0.001, 60.0));
  AddCompareCommand(app, out->cmp);
}

int CommandLineParser::Parse(int argc, const char* const* argv, CommandLine* out) {
  CLI::App& app = impl_->app;
  impl_->args = CommandLine();  // the defaults (the options are bound to these members)
  // The top level has only --help and --version: a first word that is not an option must name a
  // subcommand (CLI11 would only say "A subcommand is required").
  if (argc > 1 && argv[1] != nullptr && argv[1][0] != '-') {
    const std::string word = argv[1];
    std::string names;
    bool known = false;
    for (const CLI::App* c : app.get_subcommands([](const CLI::App*) { return true; })) {
      known = known || c->get_name() == word;
      names += (names.empty() ? "" : ", ") + c->get_name();
    }
    if (!known) {
      std::string shown = word;
      for (auto& ch : shown)
        if (ch == '\n' || ch == '\r') ch = ' ';
      std::fprintf(stderr, "kfx: error: unknown subcommand '%s' (expected one of: %s; see kfx --help)\n", shown.c_str(),
                   names.c_str());
      return 2;
    }
  }
  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return app.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return app.exit(e);
  } catch (const CLI::ParseError& e) {
    std::string msg = e.what();
    for (auto& ch : msg)
      if (ch == '\n' || ch == '\r') ch = ' ';
    std::fprintf(stderr, "kfx: error: %s (see kfx --help)\n", msg.c_str());
    return 2;
  }
  for (const auto* c : app.get_subcommands()) {
    *out = impl_->args;
    out->command = c->get_name();
    return -1;
  }
  std::fprintf(stderr, "kfx: error: expected a subcommand (see kfx --help)\n");
  return 2;
}

}  // namespace kfx::cli
