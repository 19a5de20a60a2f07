# The two commands a newcomer runs: `make test` and `make demo` (see README.md).
BUILD ?= build
JOBS  ?= 2
CMAKE_FLAGS ?= -DCMAKE_BUILD_TYPE=Release -DBURRBENCH_WERROR=ON

.PHONY: all deps configure build test test-loaded demo bench fuzz clean

all: build

deps:
	@scripts/install-deps

configure: deps
	@cmake -S . -B $(BUILD) $(CMAKE_FLAGS) >/dev/null

build: configure
	@cmake --build $(BUILD) -j $(JOBS)

test: build
	ctest --test-dir $(BUILD) --output-on-failure -j $(JOBS)

# The tests labelled `load` (acquisition's promises) beside two busy processes, as on a lab
# PC that also runs the stage software and a camera (docs/rig.md, "A loaded host").
test-loaded: build
	@scripts/test-loaded $(BUILD)

demo: build
	@scripts/demo $(BUILD)

bench: build
	@bench/run-all $(BUILD)

# libFuzzer targets (clang, own build dir build-fuzz); FUZZ_SECONDS per target, default 60.
fuzz: deps
	@bench/fuzz.sh

clean:
	rm -rf $(BUILD)
