# Thin wrapper over CMake: `make`, `make demo`, `make check`, `make bench`.
BUILD ?= build
ASAN_BUILD ?= build-asan
JOBS ?= $(shell nproc)

.PHONY: all deps configure demo check check-asan check-valgrind bench clean fuzz fuzz-smoke \
	install package

all: configure
	cmake --build $(BUILD) -j $(JOBS)

# Installs what is missing (a no-op when everything is there).
deps:
	@sh scripts/deps.sh

configure: deps
	@test -f $(BUILD)/CMakeCache.txt || cmake -S . -B $(BUILD) -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null

demo: all
	@sh scripts/demo.sh $(BUILD)/bin

# ctest, then how many tests were skipped and why (scripts/ctest-skips.sh).
check: all
	sh scripts/ctest-skips.sh $(BUILD) --output-on-failure -j $(JOBS)

# The unit, daemon and rig tests again under AddressSanitizer and
# UndefinedBehaviorSanitizer, at the small sizes valgrind uses
# (GONIO_TEST_SMALL, docs/testing-memory.md): the same code on less data, so
# CI stays within its budget; the full sizes run in `make check`.
check-asan: deps
	@test -f $(ASAN_BUILD)/CMakeCache.txt || cmake -S . -B $(ASAN_BUILD) -DCMAKE_BUILD_TYPE=Debug -DGONIO_SANITIZE=ON >/dev/null
	cmake --build $(ASAN_BUILD) -j $(JOBS)
	GONIO_TEST_SMALL=1 \
	    LSAN_OPTIONS=suppressions=$(CURDIR)/tests/lsan.supp:print_suppressions=0 \
	    sh scripts/ctest-skips.sh $(ASAN_BUILD) --output-on-failure -j $(JOBS) -L 'unit|daemon|rig'

# The tests again under valgrind's memcheck (scripts/check-valgrind.sh).
check-valgrind: all
	sh scripts/check-valgrind.sh $(BUILD) $(JOBS)

# libFuzzer runs (clang): FUZZ_SECONDS each, FUZZ_PARALLEL at a time; new
# interesting inputs are merged into fuzz/corpus/ unless FUZZ_MERGE=0
# (docs/fuzzing.md).
FUZZ_BUILD ?= build-fuzz
FUZZ_SECONDS ?= 600
FUZZ_PARALLEL ?= 1
FUZZ_MERGE ?= 1
FUZZ_TARGETS ?= $(patsubst fuzz/fuzz_%.c,%,$(filter-out fuzz/fuzz_util.c,$(wildcard fuzz/fuzz_*.c)))
fuzz: deps
	@command -v clang >/dev/null || { echo "make fuzz needs clang (apt-get install clang)"; exit 2; }
	@test -f $(FUZZ_BUILD)/CMakeCache.txt || CC=clang cmake -S . -B $(FUZZ_BUILD) -DCMAKE_BUILD_TYPE=RelWithDebInfo -DGONIO_FUZZ=ON >/dev/null
	cmake --build $(FUZZ_BUILD) -j $(JOBS) --target fuzz_all
	FUZZ_MERGE=$(FUZZ_MERGE) bash scripts/fuzz.sh $(FUZZ_BUILD)/fuzz $(FUZZ_SECONDS) $(FUZZ_PARALLEL) $(FUZZ_TARGETS)

# CI's smoke run: every target a few seconds, the committed corpora left as
# they are.
fuzz-smoke:
	$(MAKE) fuzz FUZZ_SECONDS=5 FUZZ_PARALLEL=$(JOBS) FUZZ_MERGE=0

# The Debian daemon layout of cmake/GonioInstall.cmake (/usr/bin, /etc/gonio,
# /usr/share/gonio, systemd, sysusers.d, tmpfiles.d, man pages); DESTDIR stages
# it elsewhere (docs/install.md).
DESTDIR ?=
install: all
	DESTDIR=$(DESTDIR) cmake --install $(BUILD)

# gonio_VERSION_ARCH.deb in $(BUILD) (cmake/GonioPackage.cmake).
package: all
	cd $(BUILD) && cpack -G DEB

bench: all
	@sh scripts/bench.sh $(BUILD)/bin

clean:
	rm -rf $(BUILD) $(ASAN_BUILD) $(FUZZ_BUILD)
