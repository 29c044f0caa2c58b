# Thin wrapper over scripts/ and CMake presets. `make demo` and `make test` work on a fresh
# Debian 12 machine: both install the build dependencies first (scripts/setup-deps, idempotent).
PRESET ?= cpu
BUILD_DIR := build/$(PRESET)
JOBS ?= $(shell nproc)

.PHONY: setup build test test-asan demo bench clean

setup:
	scripts/setup-deps

build: setup
	cmake --preset $(PRESET) >/dev/null
	cmake --build --preset $(PRESET) -j $(JOBS)

test: build
	ctest --preset $(PRESET) -j $(JOBS)

test-asan:
	$(MAKE) test PRESET=asan

demo: build
	scripts/demo $(BUILD_DIR)

bench: build
	scripts/setup-deps --bench
	scripts/bench-cpu $(BUILD_DIR)

clean:
	rm -rf build out
