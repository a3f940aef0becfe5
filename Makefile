# fskin: the two commands a user needs are `make demo` and `make test`.
# Both install what is missing (scripts/setup.sh) and build first.
BUILD_DIR ?= build
JOBS ?= $(shell nproc)
CMAKE_FLAGS ?=
# ccache with precompiled headers: these sloppiness flags let it reuse PCH units.
export CCACHE_SLOPPINESS := pch_defines,time_macros,include_file_mtime,include_file_ctime
# Paths relative to the checkout, so every clone shares the cache.
export CCACHE_BASEDIR ?= $(CURDIR)

.PHONY: setup configure build cli test demo demo-quadruped demo-avatar bench python sanitize sanitize-readers clean

setup:
	bash scripts/setup.sh

$(BUILD_DIR)/build.ninja:
	cmake -S . -B $(BUILD_DIR) -G Ninja -DCMAKE_BUILD_TYPE=Release $(CMAKE_FLAGS)

configure: setup $(BUILD_DIR)/build.ninja

build: configure
	cmake --build $(BUILD_DIR) -j $(JOBS)

# The command-line tool alone: what the demos run. The library's CUDA kernels
# are not among its dependencies unless LibTorch itself has CUDA (then they are
# linked in); `make build` / `make test` compile them wherever nvcc exists.
cli: configure
	cmake --build $(BUILD_DIR) -j $(JOBS) --target fskin_cli

test: build
	cd $(BUILD_DIR) && ctest --output-on-failure -j $(JOBS) --timeout 900

demo: cli
	bash scripts/demo.sh $(BUILD_DIR)/fskin demo-output

# The same job on the built-in 33-joint quadruped, with the same defaults.
demo-quadruped: cli
	FSKIN_DEMO_KIND=quadruped bash scripts/demo.sh $(BUILD_DIR)/fskin demo-quadruped

# A textured avatar learned from rendered images of the built-in character
# (Fast-SNARF sec. 7): dataset, training, PSNR per split, pictures.
demo-avatar: cli
	bash scripts/demo_avatar.sh $(BUILD_DIR)/fskin demo-avatar-output

# The Python module: build/python/fskin (use with PYTHONPATH=build/python).
python: configure
	cmake --build $(BUILD_DIR) -j $(JOBS) --target fskin_python
	@echo "import it with: PYTHONPATH=$(CURDIR)/$(BUILD_DIR)/python /usr/bin/python3 -c 'import fskin'"

bench: build
	$(BUILD_DIR)/fskin_bench

# The test suite built with AddressSanitizer + UndefinedBehaviorSanitizer in
# build-sanitize/ (not part of `make test`: slower to build and to run).
# Leak checking is off: LibTorch keeps global allocations until exit.
SANITIZE_DIR ?= build-sanitize
sanitize: setup
	cmake -S . -B $(SANITIZE_DIR) -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DFSKIN_SANITIZE=ON \
	  -DFSKIN_BUILD_BENCHMARKS=OFF $(CMAKE_FLAGS)
	cmake --build $(SANITIZE_DIR) -j $(JOBS)
	cd $(SANITIZE_DIR) && ASAN_OPTIONS=detect_leaks=0:abort_on_error=1 \
	  UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
	  ctest --output-on-failure -j $(JOBS) --timeout 1800

# The readers of untrusted files under ASan + UBSan, with their hostile-input
# tests and fuzzers (FSKIN_FUZZ_CASES per target), in minutes instead of the
# hour a cold `make sanitize` takes.
sanitize-readers: configure
	cmake --build $(BUILD_DIR) -j $(JOBS) --target fskin_reader_sanitize
	ASAN_OPTIONS=detect_leaks=0:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
	  $(BUILD_DIR)/tests/fskin_reader_sanitize

clean:
	rm -rf $(BUILD_DIR)
