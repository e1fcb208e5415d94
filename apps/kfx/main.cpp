// kfx — command-line front end: parses the command line, runs the subcommand (one file each, commands.hpp)
// and turns any error into one line on stderr and exit code 2 (docs in README.md; file formats in
// docs/formats.md).
#include <cstdio>
#include <new>
#include <string>
#include <vector>

#include "cli_args.hpp"
#include "commands.hpp"
#include "kfx/error.hpp"
#include "kfx/reproduce.hpp"

namespace kfx::cli {
namespace {

int Main(int argc, char** argv) {
  CommandLine cl;
  std::vector<std::string> papers = PaperIds();
  papers.push_back("all");
  const int rc = CommandLineParser(papers).Parse(argc, argv, &cl);
  if (rc >= 0) return rc;
  if (cl.command == "simulate") return RunSimulate(cl.sim);
  if (cl.command == "filter") return RunFilterCommand(cl.flt);
  if (cl.command == "smooth") return RunSmoothCommand(cl.smo);
  if (cl.command == "analyze") return RunAnalyze(cl.ana);
  if (cl.command == "mismatch") return RunMismatch(cl.mis);
  if (cl.command == "reproduce") return RunReproduce(cl.rep);
  if (cl.command == "compare") return RunCompare(cl.cmp);
  if (cl.command == "blockdiag") return RunBlockDiag(argc, argv, cl.bd);
  if (cl.command == "info") return RunInfo(cl.info);
  return 2;
}

}  // namespace
}  // namespace kfx::cli

int main(int argc, char** argv) {
  auto one_line = [](std::string msg) {
    for (auto& ch : msg)
      if (ch == '\n' || ch == '\r') ch = ' ';
    return msg;
  };
  try {
    kfx::cli::ChooseKernelBeforeRun(argv);
    return kfx::cli::Main(argc, argv);
  } catch (const kfx::Error& e) {
    std::fprintf(stderr, "kfx: error: %s\n", one_line(e.what()).c_str());
  } catch (const kfx::NumericalError& e) {
    std::fprintf(stderr, "kfx: numerical error: %s\n", one_line(e.what()).c_str());
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "kfx: error: out of memory\n");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "kfx: error: %s\n", one_line(e.what()).c_str());
  } catch (...) {
    std::fprintf(stderr, "kfx: error: unknown exception\n");
  }
  return 2;
}
