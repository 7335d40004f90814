# Thin wrapper over CMake: `make`, `make demo`, `make check`, `make bench`.
BUILD ?= build
ASAN_BUILD ?= build-asan
JOBS ?= $(shell nproc)

.PHONY: all deps configure demo check check-asan bench clean

all: configure
	cmake --build $(BUILD) -j $(JOBS)

# Installs what is missing (a no-op when everything is there).
deps:
	@sh scripts/deps.sh

configure: deps
	@test -f $(BUILD)/CMakeCache.txt || cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null

demo: all
	@sh scripts/demo.sh $(BUILD)/bin

check: all
	cd $(BUILD) && ctest --output-on-failure -j $(JOBS)

# The unit tests again under AddressSanitizer and UndefinedBehaviorSanitizer.
check-asan: deps
	@test -f $(ASAN_BUILD)/CMakeCache.txt || cmake -S . -B $(ASAN_BUILD) -DCMAKE_BUILD_TYPE=Debug -DGONIO_SANITIZE=ON >/dev/null
	cmake --build $(ASAN_BUILD) -j $(JOBS)
	cd $(ASAN_BUILD) && ctest --output-on-failure -j $(JOBS) -L unit

bench: all
	@sh scripts/bench.sh $(BUILD)/bin

clean:
	rm -rf $(BUILD) $(ASAN_BUILD)
