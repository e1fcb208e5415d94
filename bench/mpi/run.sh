#!/usr/bin/env bash
# The docs/scaling.md measurements: per-step time of the distributed block-diagonal filter at
# np = 1, 2 for n = 1e5 and 1e6 (c = 2, d = 1, r = 20), and the all-reduce time alone at np = 1, 2, 4.
# Usage: bench/mpi/run.sh BUILD_DIR  (a build with -DKFX_WITH_MPI=ON -DKFX_BUILD_BENCHMARKS=ON).
# As root, export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 first.
set -euo pipefail
build=${1:?usage: bench/mpi/run.sh BUILD_DIR}
b="$build/bench/mpi/bench_blockdiag_mpi"
export OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 OMPI_MCA_rmaps_base_oversubscribe=1
for n in 100000 1000000; do
  for np in 1 2; do mpirun -np $np "$b" --n $n --r 20 --steps 6 --repeats 1000; done
done
for np in 1 2 4; do mpirun -np $np "$b" --n 4096 --r 20 --steps 20 --repeats 20000; done
