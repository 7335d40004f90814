#!/usr/bin/python3
"""Every ctest test has a TIMEOUT: a test that hangs, or a helper it forked
that keeps ctest's output pipe open, then fails at its limit instead of
stalling make check (cmake/GonioTest.cmake, docs/testing-skips.md).

  check_timeouts.py CTEST BUILD_DIR
"""
import json
import subprocess
import sys


def main():
    ctest, build = sys.argv[1], sys.argv[2]
    out = subprocess.run([ctest, "--show-only=json-v1"], cwd=build, check=True,
                         capture_output=True, text=True, timeout=60).stdout
    tests = json.loads(out)["tests"]
    missing = []
    for t in tests:
        props = {p["name"]: p["value"] for p in t.get("properties", [])}
        if not props.get("TIMEOUT"):
            missing.append(t["name"])
    if len(tests) < 2:
        print("check_timeouts: ctest lists %d test(s) in %s" % (len(tests), build))
        return 1
    if missing:
        print("check_timeouts: %d of %d tests have no TIMEOUT: %s"
              % (len(missing), len(tests), " ".join(missing)))
        return 1
    print("check_timeouts: all %d tests have a TIMEOUT" % len(tests))
    return 0


if __name__ == "__main__":
    sys.exit(main())
