# Thin wrapper over scripts/ and CMake presets. `make demo` and `make test` work on a fresh
# Debian 12 machine: both install the build dependencies first (scripts/setup-deps, idempotent).
PRESET ?= cpu
BUILD_DIR := build/$(PRESET)
JOBS ?= $(shell nproc)

.PHONY: setup build test test-asan fuzz demo bench clean

setup:
	scripts/setup-deps

build: setup
	cmake --preset $(PRESET) >/dev/null
	cmake --build --preset $(PRESET) -j $(JOBS)

test: build
	ctest --preset $(PRESET) -j $(JOBS)

test-asan:
	$(MAKE) test PRESET=asan

# Every libFuzzer target of fuzz/ for FUZZ_SECONDS each, built with clang in build/fuzz
# (docs/reliability.md); fails when any of them finds a crash.
FUZZ_SECONDS ?= 60
fuzz: setup
	FUZZ_SECONDS=$(FUZZ_SECONDS) JOBS=$(JOBS) scripts/fuzz

# The demo renders on the GPU where there is one (nvcc and a working NVIDIA driver): the CUDA
# build, whose server takes the GPU with --device auto. Elsewhere the CPU build.
HAVE_GPU := $(shell test -x /usr/local/cuda/bin/nvcc && nvidia-smi -L >/dev/null 2>&1 && echo yes)
DEMO_PRESET ?= $(if $(HAVE_GPU),cuda-release,$(PRESET))

demo: setup
	cmake --preset $(DEMO_PRESET) >/dev/null
	cmake --build --preset $(DEMO_PRESET) -j $(JOBS) --target caustica caustica-server
	scripts/demo build/$(DEMO_PRESET)

bench: build
	scripts/setup-deps --bench
	scripts/bench-cpu $(BUILD_DIR)

clean:
	rm -rf build out
