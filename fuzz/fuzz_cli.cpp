// libFuzzer target: the command-line argument handling (apps/kfx/cli_args.cpp). The input is split
// at '\0' and '\n' into at most 64 arguments; the parser must return 0, 2 or -1 (a command to run)
// and never crash; a parsed command must hold the defaults for the options not given. Run with -close_fd_mask=3 to
// silence --help and the error lines.
#include <cstdint>
#include <string>
#include <vector>

#include "cli_args.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::vector<std::string> args{"kfx"};
  std::string cur;
  for (std::size_t i = 0; i < size && args.size() < 64; ++i) {
    const char c = static_cast<char>(data[i]);
    if (c == '\0' || c == '\n') {
      args.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  if (!cur.empty() && args.size() < 64) args.push_back(cur);
  std::vector<const char*> argv;
  for (const std::string& a : args) argv.push_back(a.c_str());
  argv.push_back(nullptr);
  kfx::cli::CommandLine cl;
  // One parser for the whole run (as building it costs more than parsing): Parse() must reset it.
  static kfx::cli::CommandLineParser parser({"aalto-spatial", "bernstein", "patel-toda", "all"});
  const int rc = parser.Parse(static_cast<int>(args.size()), argv.data(), &cl);
  if (rc != 0 && rc != 2 && rc != -1) __builtin_trap();
  if (rc == -1 && cl.command.empty()) __builtin_trap();
  bool steps_given = false;
  for (const std::string& a : args) steps_given = steps_given || a.find("steps") != std::string::npos;
  if (rc == -1 && !steps_given && (cl.sim.steps != 100 || cl.ana.steps != 50)) __builtin_trap();
  return 0;
}
