# shapemap — top-level entry points. See README.md.
BUILD ?= build
JOBS ?= $(shell nproc)
CMAKE_FLAGS ?=

.PHONY: build deps test demo bench check-sanitizers clean tool install

deps:
	@bash scripts/install-deps

# Ninja when installed (install-deps installs it, so it is decided after deps ran): it
# compiles the tool's own sources while the libraries are still compiling, where make's
# per-target order leaves a core idle; CMAKE_GENERATOR in the environment wins.
$(BUILD)/CMakeCache.txt: | deps
	cmake -S . -B $(BUILD) $$([ -z "$$CMAKE_GENERATOR" ] && command -v ninja >/dev/null && echo "-G Ninja") \
	  -DCMAKE_BUILD_TYPE=Release $(CMAKE_FLAGS)

# Everything: the tool, the tests, the benchmarks.
build: deps $(BUILD)/CMakeCache.txt
	cmake --build $(BUILD) -j $(JOBS)

# The command-line tool alone (no tests, no benchmarks).
tool: deps $(BUILD)/CMakeCache.txt
	cmake --build $(BUILD) -j $(JOBS) --target shapemap

test: build
	cd $(BUILD) && ctest --output-on-failure -j $(JOBS) --timeout 900

# The demo runs only the tool, so it builds only the tool.
demo: tool
	$(BUILD)/shapemap demo -o demo-output

# The tool, the static libraries, the headers, the CMake package and the Python package
# under the prefix chosen when the build folder was configured (default /usr/local:
# `cmake -S . -B build -DCMAKE_INSTALL_PREFIX=/usr` for /usr); tested by tests/install/run.sh.
install: build
	cmake --install $(BUILD)

bench: build
	bash bench/run

check-sanitizers: deps
	cmake -S . -B build-sanitize -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSHAPEMAP_SANITIZE=ON -DSHAPEMAP_BENCH=OFF
	cmake --build build-sanitize -j $(JOBS)
	cd build-sanitize && ASAN_OPTIONS=detect_leaks=0 ctest --output-on-failure -j $(JOBS) --timeout 1800

clean:
	rm -rf $(BUILD) build-sanitize
