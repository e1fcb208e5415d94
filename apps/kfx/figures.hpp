#pragma once
// Figures of the CLI's output directories, drawn by kfx.plots (python/kfx/plots.py, matplotlib).
#include <string>

namespace kfx::cli {

/// Runs kfx.plots on `out_dir` when a Python with matplotlib is there, and says on stdout what it drew
/// or why it could not (leaving the CSV data). Interpreter: $KFX_PYTHON, else the one CMake chose;
/// script: $KFX_PLOTS, else the source tree's python/kfx/plots.py, else the installed share/kfx/plots.py.
void DrawFigures(const std::string& out_dir);

}  // namespace kfx::cli
