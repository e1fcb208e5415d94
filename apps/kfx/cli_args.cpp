// The kfx command line parsed with CLI11 into the argument structs of cli_args.hpp; free of the library
// (its headers and its link), so that fuzz/fuzz_cli.cpp can compile this file alone.
#include "cli_args.hpp"

#include <CLI/CLI.hpp>
#include <cstdio>

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

// `kfx compare` (apps/kfx/compare.cpp).
namespace {

void AddCompareCommand(CLI::App& app, CompareArgs& cmp) {
  auto* c = app.add_subcommand("compare", "Compare filters on one model: exact error, cost per step, memory");
  c->add_option("model", cmp.model, "True model file (model or coupled model, docs/formats.md)")->required();
  c->add_option("-m,--method", cmp.methods, "Method specification (docs/cli.md); repeat for each method")
      ->required()
      ->take_all();
  auto* steps = c->add_option("--steps", cmp.steps, "Horizon T of the exact MSE (default 100)")
                    ->check(CLI::Range(1, 2000000000));
  c->add_flag("--stationary", cmp.stationary, "Stationary MSE as the headline (kalman = its steady state)")
      ->excludes(steps);
  c->add_option("--weight", cmp.weight, "n x n weight W of the MSE tr(W E[e e^T]) (.npy or .csv)");
  c->add_option("--monte-carlo", cmp.monte_carlo, "Also estimate the MSE by this many simulated runs")
      ->check(CLI::Range(0, 2000000000));
  c->add_option("--seed", cmp.seed, "Seed of the timing run and the Monte Carlo runs");
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
  c_sim->add_option("--steps", sim.steps, "Number of steps T")->check(CLI::Range(0, 2000000000));
  c_sim->add_option("--seed", sim.seed, "Random seed");
  c_sim->add_option("-o,--out", sim.out, "Output directory (x.npy: (T+1, n), y.npy: (T, m))")->required();
  c_sim->add_flag("--csv", sim.csv, "Write CSV instead of .npy");

  auto add_filter = [&](const char* name, const char* help, FilterArgs& a) {
    auto* c = app.add_subcommand(name, help);
    c->add_option("model", a.model, "Model file")->required();
    c->add_option("--data", a.data, "Measurements (T, m) as .npy or .csv; NaN = missing")->required();
    c->add_option("-o,--out", a.out, "Output directory")->required();
    c->add_flag("--csv", a.csv, "Write CSV instead of .npy");
    c->add_option("--form", a.form,
                  "Covariance form: joseph (default), standard, sqrt (square root), ud (Bierman-Thornton), "
                  "information (docs/robustness.md)")
        ->check(CLI::IsMember(FilterFormChoices()));
    c->add_flag("--health", a.health,
                "Monitor symmetry, definiteness and innovation consistency (NIS); reported in summary.json");
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
  c_ana->add_option("--monte-carlo", ana.monte_carlo, "Also compare exact and Monte Carlo MSE with this many runs")
      ->check(CLI::Range(0, 2000000000));
  c_ana->add_option("--steps", ana.steps, "Horizon of the exact/Monte Carlo comparison")
      ->check(CLI::Range(1, 2000000000));
  c_ana->add_option("--seed", ana.seed, "Monte Carlo seed");
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
  c_bd->add_option("--granule", bd.granule, "Subsystems per partition unit (default 1024)")
      ->check(CLI::Range(1L, 1000000000L));
  c_bd->add_option("--steps", bd.steps, "Number of steps (default: all rows of the data)")
      ->check(CLI::Range(0, 2000000000));
  AddCompareCommand(app, out->cmp);
}

int CommandLineParser::Parse(int argc, const char* const* argv, CommandLine* out) {
  CLI::App& app = impl_->app;
  impl_->args = CommandLine();  // the defaults (the options are bound to these members)
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
