// The figures of the CLI's output directories (figures.hpp): kfx.plots run on the directory.
#include "figures.hpp"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>

#include "output.hpp"

namespace fs = std::filesystem;

namespace kfx::cli {

namespace {

// The figures of `reproduce --out DIR` and `compare --out DIR` are drawn by kfx.plots (python/kfx/plots.py, matplotlib)
// when a Python with matplotlib is there; otherwise the CLI says so and leaves the CSV data. Interpreter: $KFX_PYTHON,
// else the one CMake chose (Debian's /usr/bin/python3); script: $KFX_PLOTS, else the source tree's python/kfx/plots.py,
// else the installed share/kfx/plots.py.
std::string ShellQuote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

}  // namespace

void DrawFigures(const std::string& out_dir) {
  const char* env_python = std::getenv("KFX_PYTHON");
  const char* env_script = std::getenv("KFX_PLOTS");
  const std::string python = env_python ? env_python : KFX_PYTHON_DEFAULT;
  std::string script = env_script ? env_script : KFX_PLOTS_SCRIPT;
  if (!env_script && !fs::exists(script)) script = KFX_PLOTS_INSTALLED;
  const std::string manual = "; the CSV data are in " + out_dir +
                             " (to draw them: install python3-matplotlib, then python3 python/kfx_figures.py " +
                             out_dir + ")";
  if (!fs::exists(script)) {
    std::cout << "figures: not drawn: the plotting script " << script << " is missing" << manual << "\n";
    return;
  }
  const std::string probe = ShellQuote(python) + " -c 'import matplotlib' > /dev/null 2>&1";
  if (std::system(probe.c_str()) != 0) {
    std::cout << "figures: not drawn: no Python with matplotlib (tried " << python << ")" << manual << "\n";
    return;
  }
  const std::string list = Join(out_dir, "figures.txt");
  const std::string cmd =
      ShellQuote(python) + " " + ShellQuote(script) + " " + ShellQuote(out_dir) + " > " + ShellQuote(list);
  std::cout << std::flush;
  if (std::system(cmd.c_str()) != 0) {
    std::cout << "figures: not drawn: " << python << " " << script << " failed (messages above)" << manual << "\n";
    return;
  }
  std::ifstream in(list);
  int count = 0;
  for (std::string line; std::getline(in, line);) count += !line.empty();
  if (count == 0) {
    std::cout << "figures: none to draw for this output (kfx.plots found no figure data)\n";
    return;
  }
  std::cout << "figures: " << count << " files (PNG and SVG) drawn with " << python << " (kfx.plots), listed in "
            << list << "\n";
}

}  // namespace kfx::cli
