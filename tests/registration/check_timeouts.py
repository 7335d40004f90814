#!/usr/bin/python3
"""Every ctest test has a TIMEOUT: a test that hangs, or a helper it forked
that keeps ctest's output pipe open, then fails at its limit instead of
stalling make check (cmake/GonioTest.cmake, docs/testing-skips.md).

  check_timeouts.py CTEST BUILD_DIR
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile


def list_tests(ctest, build):
    """ctest --show-only=json-v1 on a copy of the build's CTestTestfile.cmake
    tree: run in the build itself, it would rewrite the LastTest.log of the
    ctest run it is part of (scripts/ctest-skips.sh reads that log)."""
    with tempfile.TemporaryDirectory() as tmp:
        for folder, dirs, files in os.walk(build):
            dirs[:] = [d for d in dirs if d not in ("Testing", "CMakeFiles", "_CPack_Packages")]
            if "CTestTestfile.cmake" in files:
                dest = os.path.join(tmp, os.path.relpath(folder, build))
                os.makedirs(dest, exist_ok=True)
                shutil.copy(os.path.join(folder, "CTestTestfile.cmake"), dest)
        return subprocess.run([ctest, "--show-only=json-v1"], cwd=tmp, check=True,
                              capture_output=True, text=True, timeout=60).stdout


def main():
    ctest, build = sys.argv[1], sys.argv[2]
    out = list_tests(ctest, build)
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
