# kfx — the two commands of a new machine:
#   make demo   install missing Debian packages (as root), build Release, run the main job
#   make test   same set-up, build, run every test through ctest
# More: make test-asan (ASan + UBSan unit tests), make test-install (install tests with clang++),
# make test-readme (README's CMake recipe), make bench, make format-check, make install, make docs
# (the Python API reference).
SHELL := /bin/bash
BUILD ?= build
ASAN_BUILD ?= build-asan
BENCH_BUILD ?= build-bench
# The Clang sanitizer build shared by the fuzzers and make test-asan-ci (one library build for both).
SAN_BUILD ?= build-san
FUZZ_BUILD ?= $(SAN_BUILD)
# Per-target budget of make fuzz (executions) and make fuzz-smoke (seconds).
FUZZ_RUNS ?= 1000000
FUZZ_SECONDS ?= 30
JOBS ?= 2
PREFIX ?= /usr/local
# One BLAS/OpenMP thread: on a shared 2-core machine more threads are erratic.
export OPENBLAS_NUM_THREADS ?= 1
export OMP_NUM_THREADS ?= 1

# Debian packages per target, by group of tools/deps/debian.txt (the one list; README "Building from
# source" shows it): make demo/test need the build, Python, test and MPI groups (MPI so that the mpi-labelled
# tests run; a plain CMake build without it skips them). Clang (make fuzz), Google Benchmark (make bench),
# SciPy and Octave (make bench-peers) and clang-format are installed only by the targets that use them.
DEPS_BUILD := build python test mpi
KFX := $(BUILD)/bin/kfx

.PHONY: demo test deps build test-asan test-asan-ci san-configure bench format-check install clean fuzz fuzz-build fuzz-smoke

deps:
	@bash tools/install-deps.sh $(DEPS_BUILD)

build: deps
	@cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release -DCMAKE_INSTALL_PREFIX=$(PREFIX) > $(BUILD).configure.log 2>&1 || (cat $(BUILD).configure.log; exit 1)
	cmake --build $(BUILD) -j$(JOBS)

demo: build
	@bash examples/demo.sh $(KFX) $(if $(FULL),--full,)

# make test is README's "Building from source" recipe run verbatim in this tree (tests/readme/run_recipe.sh
# --in-place: `cmake -S . -B build && cmake --build build && ctest --test-dir build`), with JOBS cores and
# the output of failed tests shown, so that the recipe is tested by every CI run. The recipe builds in
# build/: with another BUILD, the same steps in $(BUILD).
ifeq ($(BUILD),build)
test: deps
	CMAKE_BUILD_PARALLEL_LEVEL=$(JOBS) CTEST_PARALLEL_LEVEL=$(JOBS) CTEST_OUTPUT_ON_FAILURE=1 \
	  bash tests/readme/run_recipe.sh --in-place .
else
test: build
	ctest --test-dir $(BUILD) --output-on-failure -j$(JOBS)
endif

# The install tests (tests/install/) with Clang installed, so that the clang++ consumers run too (make test
# skips them where clang++ is missing).
.PHONY: test-install test-readme
test-install: build
	@bash tools/install-deps.sh $(DEPS_BUILD) fuzz
	ctest --test-dir $(BUILD) --output-on-failure -j$(JOBS) -L install

# README's "Building from source" recipe run verbatim on a copy of the tree (tests/readme/run_recipe.sh):
# also the tracked and untracked files only, without this tree's build/ (make test runs it in place).
test-readme: deps
	bash tests/readme/run_recipe.sh .

# Unit tests under AddressSanitizer + UndefinedBehaviorSanitizer, with Eigen's assertions on
# (-O1, no NDEBUG).
test-asan: deps
	@cmake -S . -B $(ASAN_BUILD) -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g" \
	  -DKFX_SANITIZE=ON > $(ASAN_BUILD).configure.log 2>&1 || (cat $(ASAN_BUILD).configure.log; exit 1)
	cmake --build $(ASAN_BUILD) -j$(JOBS)
	ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
	  ctest --test-dir $(ASAN_BUILD) --output-on-failure -j$(JOBS)

# CI's sanitizer step (.ci/run): one Clang build, $(SAN_BUILD), for the unit tests and the fuzzers. The
# library's objects are compiled once with -fsanitize=address,undefined plus libFuzzer's coverage
# instrumentation (-fsanitize=fuzzer-no-link), at -O1 with line tables only and Eigen's assertions on;
# the unit-test executables link them without libFuzzer, the fuzz targets with it (make fuzz-smoke,
# make fuzz reuse the build). No CLI, Python module, reproductions, benchmarks or examples; ccache when
# installed. The unit tests run with the machine's own OpenBLAS kernels, then the tests of the
# small-product and health-monitor paths (SAN_PRESCOTT_TESTS) again with OPENBLAS_CORETYPE=Prescott,
# the kernels of the Intel machines where DSYMV read past small operands (docs/robustness.md, class 16):
# every form of the filter and its health monitor (where the over-read was), the smoother, the
# validators' small eigendecompositions, the DARE and Lyapunov solvers, the block-diagonal filters and
# Algorithm 2.3. (ASan does not see inside OpenBLAS: this pass catches a kernel's crash, not its reads.)
ASAN_ENV := ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
SAN_PRESCOTT_TESTS ?= ^(BlasCalls|FilterHealth|RobustFilter|KalmanFilter|RtsSmoother|Model|Dare|GeneralDare|GeneralizedLyapunov|Lyapunov|BlockDiagonal|SubspaceFilterTest)
san-configure:
	@bash tools/install-deps.sh build test fuzz
	@cmake -S . -B $(SAN_BUILD) -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_COMPILER=clang++ \
	  -DCMAKE_CXX_FLAGS_DEBUG="-O1 -gline-tables-only" -DKFX_SANITIZE=ON -DKFX_BUILD_FUZZERS=ON \
	  -DKFX_BUILD_APPS=OFF -DKFX_BUILD_PYTHON=OFF -DKFX_WITH_MPI=OFF \
	  $(if $(shell command -v ccache),-DCMAKE_CXX_COMPILER_LAUNCHER=ccache,) \
	  > $(SAN_BUILD).configure.log 2>&1 || (cat $(SAN_BUILD).configure.log; exit 1)

test-asan-ci: san-configure
	cmake --build $(SAN_BUILD) -j$(JOBS) --target kfx_unit_tests
	$(ASAN_ENV) ctest --test-dir $(SAN_BUILD) -L unit --output-on-failure -j$(JOBS)
	$(ASAN_ENV) OPENBLAS_CORETYPE=Prescott ctest --test-dir $(SAN_BUILD) -L unit -R '$(SAN_PRESCOTT_TESTS)' \
	  --output-on-failure -j$(JOBS)

bench:
	@bash tools/install-deps.sh build bench
	@cmake -S . -B $(BENCH_BUILD) -DCMAKE_BUILD_TYPE=Release -DKFX_BUILD_BENCHMARKS=ON -DKFX_BUILD_TESTS=OFF > $(BENCH_BUILD).configure.log 2>&1 || (cat $(BENCH_BUILD).configure.log; exit 1)
	cmake --build $(BENCH_BUILD) -j$(JOBS)
	bash bench/run.sh $(BENCH_BUILD)

# kfx vs SLICOT / SciPy / Octave / numpy (bench/peers/peers.py): one run, one BLAS thread, process
# CPU time; writes $(BENCH_BUILD)/peers/peers.{json,md}, then many small filters from Python against a vectorised
# numpy filter and the traffic bound (bench/many_filters.py -> $(BENCH_BUILD)/peers/many_filters.md, written whole
# once the run has finished). QUICK=1: small sizes only. Not part of make test.
.PHONY: bench-peers
bench-peers:
	@bash tools/install-deps.sh build bench peers python
	@cmake -S . -B $(BENCH_BUILD) -DCMAKE_BUILD_TYPE=Release -DKFX_BUILD_BENCHMARKS=ON -DKFX_BUILD_TESTS=OFF > $(BENCH_BUILD).configure.log 2>&1 || (cat $(BENCH_BUILD).configure.log; exit 1)
	cmake --build $(BENCH_BUILD) -j$(JOBS) --target kfx_peers kfx_python
	/usr/bin/python3 bench/peers/peers.py --driver $(BENCH_BUILD)/bench/kfx_peers --out $(BENCH_BUILD)/peers $(if $(QUICK),--quick,)
	PYTHONPATH=$(BENCH_BUILD)/python /usr/bin/python3 bench/many_filters.py $(if $(QUICK),--n 10000 --steps 100,) > $(BENCH_BUILD)/peers/many_filters.md.part
	mv $(BENCH_BUILD)/peers/many_filters.md.part $(BENCH_BUILD)/peers/many_filters.md
	cat $(BENCH_BUILD)/peers/many_filters.md
# libFuzzer targets (readers of .npy, CSV, model, coupled-model and error-range files; CLI arguments)
# under ASan + UBSan, in the sanitizer build above. fuzz: FUZZ_RUNS executions each; fuzz-smoke:
# FUZZ_SECONDS each.
fuzz-build: san-configure
	cmake --build $(FUZZ_BUILD) -j$(JOBS) --target kfx_fuzzers

fuzz: fuzz-build
	bash fuzz/run.sh $(FUZZ_BUILD) -runs=$(FUZZ_RUNS)

fuzz-smoke: fuzz-build
	bash fuzz/run.sh $(FUZZ_BUILD) -max_total_time=$(FUZZ_SECONDS)

# The Python API reference (docs/api/, Sphinx autodoc): only the Python module is built for it; the
# docstrings carry the C++ doc comments (python/gen_cpp_docs.py). -W: a broken reference fails.
.PHONY: docs
docs: deps
	@bash tools/install-deps.sh docs
	@cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release -DCMAKE_INSTALL_PREFIX=$(PREFIX) > $(BUILD).configure.log 2>&1 || (cat $(BUILD).configure.log; exit 1)
	cmake --build $(BUILD) -j$(JOBS) --target kfx_python
	PYTHONPATH=$(BUILD)/python /usr/bin/python3 -m sphinx -b html -q -W --keep-going docs/api $(BUILD)/docs/html
	@echo "kfx: API reference in $(BUILD)/docs/html/index.html"

format-check:
	@bash tools/install-deps.sh format
	@clang-format --dry-run -Werror $$(git ls-files '*.cpp' '*.hpp')

install: build
	cmake --install $(BUILD)

clean:
	rm -rf $(BUILD) $(ASAN_BUILD) $(BENCH_BUILD) $(BUILD).configure.log $(ASAN_BUILD).configure.log demo-out
	rm -rf $(SAN_BUILD) $(SAN_BUILD).configure.log
