#pragma once
// The subcommands of kfx, one source file each (simulate.cpp, filter.cpp, analyze.cpp, mismatch.cpp,
// reproduce.cpp, blockdiag.cpp, info.cpp): the entry points main.cpp dispatches to. Each returns the exit code;
// bad input throws kfx::Error, which main.cpp prints as one line (exit code 2).
#include "cli_args.hpp"

namespace kfx::cli {

/// `kfx simulate MODEL --steps T --seed S -o DIR`: x and y of one simulated run.
int RunSimulate(const SimulateArgs& args);

/// `kfx filter MODEL --data Y -o DIR`: the Kalman filter's estimates, covariance diagonals, innovations
/// and summary.json.
int RunFilterCommand(const FilterArgs& args);

/// `kfx filter MODEL --method SPEC --data Y -o DIR` (filter_method.cpp): the method's estimates x_filt and
/// summary.json; a `kalman` spec runs RunFilterCommand with its form.
int RunFilterMethod(const FilterArgs& args);

/// `kfx compare MODEL --method SPEC ...` (compare.cpp): one row per method beside the optimal Kalman filter.
int RunCompare(const CompareArgs& args);

/// `kfx smooth MODEL --data Y -o DIR`: the Rauch-Tung-Striebel smoother's estimates and covariance
/// diagonals, and summary.json.
int RunSmoothCommand(const FilterArgs& args);

/// `kfx analyze MODEL [--design D] [--monte-carlo N] [--input G]`: the steady state (DARE) and, optionally, the
/// exact against the Monte Carlo MSE (with the known input G when MODEL has fields G, D).
int RunAnalyze(const AnalyzeArgs& args);

/// `kfx mismatch MODEL --ranges R`: worst case over element-wise error ranges and the Patel-Toda bounds.
int RunMismatch(const MismatchArgs& args);

/// `kfx reproduce PAPER [--json F] [--out DIR]`: a paper's published numbers beside kfx's, and figures.
int RunReproduce(const ReproduceArgs& args);

/// `kfx blockdiag MODEL --data Y -o DIR`: the block-diagonal (or banded) filter of a coupled model, over
/// MPI when kfx is built with KFX_WITH_MPI (mpirun -np N kfx blockdiag ...), else in one process. With MPI,
/// argc and argv go to MPI_Init, and errors are printed here (one line, by the rank that failed): exit code 2.
int RunBlockDiag(int argc, char** argv, const BlockDiagArgs& args);

/// `kfx info [--json]`: the BLAS and LAPACK libraries, versions, the kernel in use against the CPU's best
/// vector level (with advice when it is below), threads, the kernel self-test and a measured DGEMM rate.
/// Exit code 1 when the kernel self-test fails.
int RunInfo(const InfoArgs& args);

/// Called first in main: when the OpenBLAS kernel the library chose is below the CPU (ChooseBlasKernel),
/// re-executes kfx with OPENBLAS_CORETYPE set; the re-executed process keeps that kernel only if it loaded
/// and passes CheckBlasKernel, else re-executes once more with the library's own choice (docs/performance.md).
/// KFX_BLAS_KERNEL=library or a user's OPENBLAS_CORETYPE turn it off. Returns when nothing is to change.
void ChooseKernelBeforeRun(char** argv);

}  // namespace kfx::cli
