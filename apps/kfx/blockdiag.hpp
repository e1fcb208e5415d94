#pragma once
// `kfx blockdiag MODEL --data Y -o DIR`: the block-diagonal (or banded) filter of a coupled model,
// over MPI when kfx is built with KFX_WITH_MPI (mpirun -np N kfx blockdiag ...), else in one process.
#include <CLI/CLI.hpp>
#include <string>

namespace kfx::cli {

struct BlockDiagArgs {
  std::string model, data, out, filter = "block-diagonal";
  long granule = 1024;
  int steps = -1;
};

/// Adds the subcommand's options to `cmd`.
void AddBlockDiagOptions(CLI::App* cmd, BlockDiagArgs* args);
/// Runs it; errors are printed (one line, by the rank that failed) and give exit code 2.
int RunBlockDiag(int argc, char** argv, const BlockDiagArgs& args);

}  // namespace kfx::cli
