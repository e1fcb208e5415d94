#pragma once
// `kfx blockdiag MODEL --data Y -o DIR`: the block-diagonal (or banded) filter of a coupled model,
// over MPI when kfx is built with KFX_WITH_MPI (mpirun -np N kfx blockdiag ...), else in one process.
#include "cli_args.hpp"  // BlockDiagArgs

namespace kfx::cli {

/// Runs it; errors are printed (one line, by the rank that failed) and give exit code 2.
int RunBlockDiag(int argc, char** argv, const BlockDiagArgs& args);

}  // namespace kfx::cli
