#!/usr/bin/env bash
# The install tests (ctest -L install; tests/CMakeLists.txt registers them). Steps:
#   run.sh prefix BUILD_DIR PREFIX                 install kfx's own build tree into PREFIX
#   run.sh subproject SRC WORK PREFIX SHARED [LAUNCHER]
#        a project with kfx as add_subdirectory (library only, BUILD_SHARED_LIBS=SHARED): builds and runs
#        its consumer, then installs (kfx included) into PREFIX
#   run.sh cmake CXX SRC PREFIX WORK               find_package(kfx) consumer built with compiler CXX at its
#                                                  default standard, run
#   run.sh mpi SRC PREFIX WORK MPIEXEC             find_package(kfx COMPONENTS mpi) consumer under mpirun -np 2
#   run.sh pkgconfig SRC PREFIX WORK               g++ with `pkg-config --cflags --libs kfx`, run
# Exit 77 (ctest: skipped) when a tool the step needs is missing, saying which.
set -euo pipefail
step=$1
shift
skip() { echo "SKIPPED: $*"; exit 77; }
quiet() {  # runs a command, shows its output only when it fails
  local log
  log=$(mktemp)
  if ! "$@" > "$log" 2>&1; then cat "$log"; rm -f "$log"; echo "FAILED: $*"; exit 1; fi
  rm -f "$log"
}
check_mpi_header() {  # kfx/mpi.hpp is installed exactly when kfx::kfx_mpi is
  local with_mpi=no header=no
  compgen -G "$1/lib*/cmake/kfx/kfxMpiTargets.cmake" > /dev/null && with_mpi=yes
  [[ -f "$1/include/kfx/mpi.hpp" ]] && header=yes
  [[ $with_mpi == "$header" ]] || { echo "FAILED: kfx_mpi installed: $with_mpi, kfx/mpi.hpp installed: $header"; exit 1; }
}
case "$step" in
  prefix)
    rm -rf "$2"
    quiet cmake --install "$1" --prefix "$2"
    check_mpi_header "$2"
    echo "installed $1 into $2"
    ;;
  subproject)
    src=$1 work=$2 prefix=$3 shared=$4 launcher=${5:-}
    # No build type (-O0): this checks the packaging (exports, SOVERSION, RUNPATH, the library-only
    # defaults), not generated code; a Release build of the library took 6-9 of make test's minutes.
    args=(-DKFX_SOURCE_DIR="$src" -DBUILD_SHARED_LIBS="$shared" -DCMAKE_BUILD_TYPE=)
    # ccache cannot reuse precompiled headers: with a launcher, no PCH.
    [[ -n "$launcher" ]] && args+=(-DCMAKE_CXX_COMPILER_LAUNCHER="$launcher" -DKFX_PCH=OFF)
    quiet cmake -S "$src/tests/install/subproject" -B "$work" "${args[@]}"
    quiet cmake --build "$work" -j"${CMAKE_BUILD_PARALLEL_LEVEL:-2}"
    "$work/consumer"
    rm -rf "$prefix"
    quiet cmake --install "$work" --prefix "$prefix"
    check_mpi_header "$prefix"
    ls "$prefix"/lib*/libkfx*
    ;;
  cmake)
    cxx=$1 src=$2 prefix=$3 work=$4
    command -v "$cxx" > /dev/null || skip "no $cxx on this machine (Debian: apt-get install clang; make test-install installs it)"
    rm -rf "$work"
    quiet cmake -S "$src/tests/install/consumer" -B "$work" -DCMAKE_PREFIX_PATH="$prefix" \
      -DCMAKE_CXX_COMPILER="$cxx" -DCMAKE_BUILD_TYPE=Release
    quiet cmake --build "$work"
    echo "$("$cxx" --version | head -1); default standard: $(echo __cplusplus | "$cxx" -x c++ -E -P - | tail -1)"
    "$work/consumer"
    ;;
  mpi)
    src=$1 prefix=$2 work=$3 mpiexec=$4
    compgen -G "$prefix/lib*/cmake/kfx/kfxMpiTargets.cmake" > /dev/null ||
      skip "kfx was built without MPI (no Open MPI found: Debian libopenmpi-dev openmpi-bin)"
    command -v "$mpiexec" > /dev/null || skip "no $mpiexec on this machine"
    rm -rf "$work"
    quiet cmake -S "$src/tests/install/consumer" -B "$work" -DCMAKE_PREFIX_PATH="$prefix" -DKFX_CONSUMER_MPI=ON \
      -DCMAKE_BUILD_TYPE=Release
    quiet cmake --build "$work"
    OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_btl=self,vader \
      OMPI_MCA_btl_vader_single_copy_mechanism=none OMPI_MCA_oob_tcp_if_include=lo \
      "$mpiexec" -np 2 --oversubscribe "$work/mpi_consumer"
    ;;
  pkgconfig)
    src=$1 prefix=$2 work=$3
    command -v pkg-config > /dev/null || skip "no pkg-config on this machine (Debian: pkg-config)"
    rm -rf "$work"
    mkdir -p "$work"
    libdir=$(dirname "$(compgen -G "$prefix/lib*/pkgconfig/kfx.pc" | head -1)")/..
    export PKG_CONFIG_PATH="$libdir/pkgconfig"
    echo "pkg-config kfx $(pkg-config --modversion kfx): $(pkg-config --cflags --libs kfx)"
    # g++ at its default standard (C++17 since g++ 11); the .pc file does not force one.
    g++ -O1 "$src/tests/install/consumer/consumer.cpp" -o "$work/consumer" $(pkg-config --cflags --libs kfx)
    LD_LIBRARY_PATH="$libdir${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}" "$work/consumer"
    ;;
  *)
    echo "run.sh: unknown step $step" >&2
    exit 2
    ;;
esac
