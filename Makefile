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
FUZZ_BUILD ?= build-fuzz
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

.PHONY: demo test deps build test-asan test-asan-ci bench format-check install clean fuzz fuzz-build fuzz-smoke

deps:
	@bash tools/install-deps.sh $(DEPS_BUILD)

build: deps
	@cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=Release -DCMAKE_INSTALL_PREFIX=$(PREFIX) > $(BUILD).configure.log 2>&1 || (cat $(BUILD).configure.log; exit 1)
	cmake --build $(BUILD) -j$(JOBS)

demo: build
	@bash examples/demo.sh $(KFX) $(if $(FULL),--full,)

test: build
	ctest --test-dir $(BUILD) --output-on-failure -j$(JOBS)

# The install tests (tests/install/) with Clang installed, so that the clang++ consumers run too (make test
# skips them where clang++ is missing).
.PHONY: test-install test-readme
test-install: build
	@bash tools/install-deps.sh $(DEPS_BUILD) fuzz
	ctest --test-dir $(BUILD) --output-on-failure -j$(JOBS) -L install

# README's "Building from source" recipe run verbatim on a copy of the tree (tests/readme/run_recipe.sh).
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

# CI's sanitizer step (.ci/run): the same ASan + UBSan build, but only what the unit label needs (no
# CLI, no Python module, no reproductions), ccache when installed; the unit tests run once with the
# machine's own OpenBLAS kernels and once with OPENBLAS_CORETYPE=Prescott, the kernels of the Intel
# machines where DSYMV read past small operands (docs/robustness.md, class 16).
ASAN_ENV := ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
test-asan-ci: deps
	@cmake -S . -B $(ASAN_BUILD) -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g" -DKFX_SANITIZE=ON \
	  -DKFX_BUILD_APPS=OFF $(if $(shell command -v ccache),-DCMAKE_CXX_COMPILER_LAUNCHER=ccache,) \
	  > $(ASAN_BUILD).configure.log 2>&1 || (cat $(ASAN_BUILD).configure.log; exit 1)
	cmake --build $(ASAN_BUILD) -j$(JOBS) --target kfx_unit_tests
	$(ASAN_ENV) ctest --test-dir $(ASAN_BUILD) -L unit --output-on-failure -j$(JOBS)
	$(ASAN_ENV) OPENBLAS_CORETYPE=Prescott ctest --test-dir $(ASAN_BUILD) -L unit --output-on-failure -j$(JOBS)

bench:
	@bash tools/install-deps.sh build bench
	@cmake -S . -B $(BENCH_BUILD) -DCMAKE_BUILD_TYPE=Release -DKFX_BUILD_BENCHMARKS=ON -DKFX_BUILD_TESTS=OFF > $(BENCH_BUILD).configure.log 2>&1 || (cat $(BENCH_BUILD).configure.log; exit 1)
	cmake --build $(BENCH_BUILD) -j$(JOBS)
	bash bench/run.sh $(BENCH_BUILD)

# kfx vs SLICOT / SciPy / Octave / numpy (bench/peers/peers.py): one run, one BLAS thread, process
# CPU time; writes $(BENCH_BUILD)/peers/peers.{json,md}. QUICK=1: small sizes only. Not part of make test.
.PHONY: bench-peers
bench-peers:
	@bash tools/install-deps.sh build bench peers
	@cmake -S . -B $(BENCH_BUILD) -DCMAKE_BUILD_TYPE=Release -DKFX_BUILD_BENCHMARKS=ON -DKFX_BUILD_TESTS=OFF > $(BENCH_BUILD).configure.log 2>&1 || (cat $(BENCH_BUILD).configure.log; exit 1)
	cmake --build $(BENCH_BUILD) -j$(JOBS) --target kfx_peers
	/usr/bin/python3 bench/peers/peers.py --driver $(BENCH_BUILD)/bench/kfx_peers --out $(BENCH_BUILD)/peers $(if $(QUICK),--quick,)
# libFuzzer targets (readers of .npy, CSV, model files; CLI arguments) under ASan + UBSan, built
# from the reader sources only. fuzz: FUZZ_RUNS executions each; fuzz-smoke: FUZZ_SECONDS each.
fuzz-build:
	@bash tools/install-deps.sh build fuzz
	@cmake -S . -B $(FUZZ_BUILD) -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_COMPILER=clang++ -DKFX_BUILD_FUZZERS=ON \
	  -DKFX_BUILD_TESTS=OFF -DKFX_BUILD_APPS=OFF -DKFX_PCH=OFF > $(FUZZ_BUILD).configure.log 2>&1 || (cat $(FUZZ_BUILD).configure.log; exit 1)
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
	rm -rf $(FUZZ_BUILD) $(FUZZ_BUILD).configure.log
