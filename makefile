# volknit makefile.
#
#   make          library (lib/libvolknit.a) and driver (bin/volknit)
#   make run      install missing Debian packages (as root), build, run the demo scene
#   make check    build and run the tests with 1 and 2 MPI ranks
#   make bench    build and run the benchmarks (printed tables)
#   make fuzz     build the libFuzzer targets with clang and run each for FUZZ_TIME s
#   make examples build the example programs
#   make clean
#
# PETSc, SLEPc and HDF5 come from pkg-config; METIS is linked directly.

PKGS      := petsc slepc hdf5-openmpi
CC        := mpicc
CSTD      := -std=c99 -D_POSIX_C_SOURCE=200809L
OPT       ?= -O3 -g
# ARCH: code generation for the host, e.g. make ARCH=-march=native (AVX2 or
# AVX-512 lanes for the PD local step's batched 3x3 SVDs, 8 tets a batch
# where AVX-512 is on; the binaries then need a CPU like the build
# machine's; `make clean` first).  Empty by default: portable x86-64.
# docs/BENCHMARKS.md has the local step's ns per tet for both.
ARCH      ?=
# WERROR=1 turns warnings into errors (CI builds so; the build is warning-free).
WARN      := -Wall -Wextra $(if $(WERROR),-Werror)
# Evaluated lazily so that `make run` can install the packages first.
PKG_CFLAGS = $(shell pkg-config --cflags $(PKGS))
PKG_LIBS   = $(shell pkg-config --libs $(PKGS))
# CHOLMOD (SuiteSparse, which Debian's PETSc is built with), called directly
# by the PC subtrees (src/sim/pc_subtrees.c).
SUITESPARSE_CFLAGS ?= -I/usr/include/suitesparse
SUITESPARSE_LIBS   ?= -lcholmod -lsuitesparseconfig
# LAPACK and BLAS (which petsc-dev brings): the dense factor of its separators
# there, and their Schur complement by BLAS syrk.
LAPACK_LIBS        ?= -llapack -lblas
CFLAGS     = $(CSTD) $(OPT) $(ARCH) $(WARN) -Iinclude $(PKG_CFLAGS) $(SUITESPARSE_CFLAGS)
LDLIBS     = $(PKG_LIBS) $(SUITESPARSE_LIBS) $(LAPACK_LIBS) -lmetis -lm
MPIEXEC   ?= mpiexec
FUZZ_TIME ?= 60

LIB_SRC   := $(sort $(wildcard src/util/*.c src/yarn/*.c src/mesh/*.c src/material/*.c src/scene/*.c src/sim/*.c src/rod/*.c src/yls/*.c src/fit/*.c src/report/*.c src/app/*.c))
LIB_OBJ   := $(LIB_SRC:src/%.c=build/%.o)
LIB       := lib/libvolknit.a
BIN       := bin/volknit
TEST_SRC  := $(sort $(wildcard tests/test_*.c tests/tool_*.c))
TEST_BIN  := $(TEST_SRC:tests/%.c=bin/tests/%)
BENCH_SRC := $(sort $(wildcard tests/bench/bench_*.c))
BENCH_BIN := $(BENCH_SRC:tests/bench/%.c=bin/bench/%)
EX_SRC    := $(sort $(wildcard examples/*.c))
EX_BIN    := $(EX_SRC:examples/%.c=bin/examples/%)
FUZZ_SRC  := $(sort $(wildcard tests/fuzz/fuzz_*.c))
FUZZ_BIN  := $(FUZZ_SRC:tests/fuzz/%.c=bin/fuzz/%)

.PHONY: all run check bench fidelity fuzz examples benchmarks clean deps tests
.DEFAULT_GOAL := all

all: $(LIB) $(BIN)

deps:
	@.ci/ensure-packages

# The entry points that must work on a fresh machine check the packages
# first, then build in a sub-make (pkg-config needs the packages).
run: deps
	@$(MAKE) --no-print-directory all
	OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 $(MPIEXEC) -n 1 $(BIN) run -options_file options/demo.opts

check: deps
	@$(MAKE) --no-print-directory all tests examples
	@tests/run_tests.sh

bench: deps
	@$(MAKE) --no-print-directory all $(BENCH_BIN)
	@tests/bench/run_bench.sh
	@echo
	@tests/bench/run_fit_bench.sh

fidelity: deps
	@$(MAKE) --no-print-directory all
	@tests/bench/run_fidelity.sh

tests: $(TEST_BIN)
examples: $(EX_BIN)
benchmarks: $(BENCH_BIN)

$(LIB): $(LIB_OBJ)
	@mkdir -p $(@D)
	ar rcs $@ $^

# The PD local step's 3x3 kernels (SVD, volume projection) work on
# VK_SVD3_BATCH tets in SIMD lanes;
# GCC vectorizes their square roots and selects only without errno and
# floating-point trap semantics (neither is used by volknit).
VEC_FLAGS := -fno-math-errno -fno-trapping-math -fopenmp-simd
build/material/svd3.o build/material/projection.o: CFLAGS += $(VEC_FLAGS)
# The bending Hessian is a complex-step derivative: without this GCC calls
# __divdc3 (C99 Annex G Inf/NaN recovery) for every complex division, a
# seventh of a yarn-level run.  Fortran rules keep the range reduction.
build/rod/elements.o: CFLAGS += -fcx-fortran-rules

# The option names in the sources, for the "did you mean" of an option
# nobody read (src/app/options_check.c).
build/known_options.inc: $(LIB_SRC) src/volknit.c
	@mkdir -p $(@D)
	grep -ho '"-[a-z][a-z0-9_]*"' $^ | sort -u | sed 's/$$/,/' > $@
build/app/options_check.o: build/known_options.inc
build/app/options_check.o: CFLAGS += -Ibuild

# Header dependencies come from the compiler (-MMD): a changed header
# rebuilds only the objects and programs that include it.
DEPFLAGS = -MMD -MP
build/%.o: src/%.c
	@mkdir -p $(@D)
	$(CC) $(CFLAGS) $(DEPFLAGS) -Isrc -c $< -o $@

$(BIN): src/volknit.c $(LIB)
	@mkdir -p $(@D)
	$(CC) $(CFLAGS) $(DEPFLAGS) $< -o $@ $(LIB) $(LDLIBS)

bin/tests/%: tests/%.c $(LIB)
	@mkdir -p $(@D)
	$(CC) $(CFLAGS) $(DEPFLAGS) -Itests $< -o $@ $(LIB) $(LDLIBS)

bin/bench/%: tests/bench/%.c $(LIB)
	@mkdir -p $(@D)
	$(CC) $(CFLAGS) $(DEPFLAGS) $< -o $@ $(LIB) $(LDLIBS)

bin/examples/%: examples/%.c $(LIB)
	@mkdir -p $(@D)
	$(CC) $(CFLAGS) $(DEPFLAGS) $< -o $@ $(LIB) $(LDLIBS)

# libFuzzer targets: the library sources again, built once with clang and
# sanitizers into their own archive, then one binary per reader.
FUZZ_SAN    = address,undefined
FUZZ_CFLAGS = $(CSTD) -O1 -g -Iinclude -Isrc -Ibuild $(PKG_CFLAGS) $(SUITESPARSE_CFLAGS) $(shell mpicc --showme:compile)
FUZZ_LIBS   = $(PKG_LIBS) $(SUITESPARSE_LIBS) $(LAPACK_LIBS) $(shell mpicc --showme:link) -lmetis -lm
FUZZ_OBJ   := $(LIB_SRC:src/%.c=build/fuzz/%.o)
FUZZ_LIB   := lib/libvolknit_fuzz.a
build/fuzz/%.o: src/%.c
	@mkdir -p $(@D)
	clang $(FUZZ_CFLAGS) -fsanitize=fuzzer-no-link,$(FUZZ_SAN) $(DEPFLAGS) -c $< -o $@
build/fuzz/app/options_check.o: build/known_options.inc
$(FUZZ_LIB): $(FUZZ_OBJ)
	@mkdir -p $(@D)
	ar rcs $@ $^
bin/fuzz/%: tests/fuzz/%.c $(FUZZ_LIB)
	@mkdir -p $(@D)
	clang $(FUZZ_CFLAGS) -fsanitize=fuzzer,$(FUZZ_SAN) $(DEPFLAGS) $< -o $@ $(FUZZ_LIB) $(FUZZ_LIBS)

fuzz: deps
	@command -v clang >/dev/null || { echo "make fuzz needs clang: apt-get install -y clang" >&2; exit 1; }
	@$(MAKE) --no-print-directory $(FUZZ_BIN)
	@tests/fuzz/run_fuzz.sh $(FUZZ_TIME)

clean:
	rm -rf build lib bin tests/out

-include $(wildcard build/*/*.d build/fuzz/*/*.d bin/*.d bin/*/*.d)
