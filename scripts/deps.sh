#!/bin/sh
# Install every Debian package gonio builds, tests and benchmarks with.
# Non-interactive and idempotent; quiet unless something fails.
set -eu

PACKAGES="build-essential cmake pkg-config git
libgsl-dev libyaml-dev libjansson-dev libcmocka-dev libopenexr-dev
libmodbus-dev libusb-1.0-0-dev umockdev libumockdev-dev zlib1g-dev
libpng-dev openexr
python3-serial python3-pytest python3-pymodbus python3-serial-asyncio python3-scipy
valgrind"
# report/: plots to PNG (librsvg, cairo) with a font for their text; chromium
# opens the study report headless in a test (docs/report.md)
PACKAGES="$PACKAGES librsvg2-dev libcairo2-dev fonts-dejavu-core chromium"
# make fuzz (libFuzzer), which CI runs for a few seconds a target (.ci/run)
PACKAGES="$PACKAGES clang"
# the study's GNU parallel recipe runs in a test (docs/study.md); make package
# builds the .deb with dpkg-deb under fakeroot (docs/install.md)
PACKAGES="$PACKAGES parallel dpkg-dev fakeroot"
# gonio live serves its page with libmicrohttpd; its test drives chromium
# through chromium-driver and selenium (docs/live.md)
PACKAGES="$PACKAGES libmicrohttpd-dev chromium-driver python3-selenium"
# goniod's event-model documents (uids: libuuid), validated in a test against
# Bluesky's schemas (docs/protocol.md)
PACKAGES="$PACKAGES uuid-dev python3-jsonschema"
# the study's Slurm job array runs in a test on a one-node Slurm it starts
# (docs/study.md)
PACKAGES="$PACKAGES slurmctld slurmd slurm-client munge"

missing=""
for p in $PACKAGES; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "ok installed" || missing="$missing $p"
done
[ -z "$missing" ] && exit 0

SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
log=$(mktemp)
if ! { $SUDO apt-get update -qq && \
       DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends $missing; } >"$log" 2>&1; then
    cat "$log" >&2
    echo "deps.sh: installing$missing failed" >&2
    rm -f "$log"
    exit 1
fi
rm -f "$log"
