#!/usr/bin/python3
"""Skips that show, for the Python tests. ctest reports a test as skipped
only when it exits 77 (SKIP_RETURN_CODE), but unittest and pytest exit 0
when tests were skipped, which ctest shows as Passed though nothing ran.
Like tests/gonio_test.h for the cmocka tests, a run in which a test skipped
and none failed exits 77, with one "SKIPPED: test: why" line per skip
(what scripts/ctest-skips.sh lists after make check).

  ctest_skips.py FILE.py ARGS...   run a unittest file (its unittest.main())
  pytest -p ctest_skips ...        the same for pytest (PYTHONPATH=tests)

shared_or_skip() is gonio_test_shared_or_skip() (tests/gonio_test.h) for a
Python test that needs the shared data folder.
"""
import os
import runpy
import sys
import unittest

SKIPPED = 77


def shared_or_skip():
    """The shared data folder ($GONIO_SHARED, else ../shared beside the
    repository), or skip the calling test (unittest or pytest) saying why.
    With GONIO_REQUIRE_SHARED set (CI, which has the data) a missing folder
    fails the test instead, so that no data test is skipped unseen."""
    here = os.path.dirname(os.path.abspath(__file__))
    folder = os.environ.get("GONIO_SHARED") or os.path.join(here, "..", "..", "shared")
    if os.path.isdir(folder):
        return folder
    if os.environ.get("GONIO_REQUIRE_SHARED", "0") not in ("", "0"):
        raise AssertionError("shared data folder not found (%s), and GONIO_REQUIRE_SHARED is set"
                             % folder)
    raise unittest.SkipTest("shared data folder not found (set GONIO_SHARED or put ../shared "
                            "beside the repository)")


def unittest_main(*args, **kwargs):
    """unittest.main for the file run below: exit 1 on a failure, else 77
    when a test skipped, else 0."""
    kwargs["exit"] = False
    result = unittest.TestProgram(*args, **kwargs).result
    for test, why in result.skipped:
        sys.stderr.write("SKIPPED: %s: %s\n" % (test.id(), why))
    if not result.wasSuccessful():
        sys.exit(1)
    sys.exit(SKIPPED if result.skipped else 0)


def pytest_sessionfinish(session, exitstatus):
    reporter = session.config.pluginmanager.get_plugin("terminalreporter")
    if exitstatus == 0 and reporter is not None and reporter.stats.get("skipped"):
        session.exitstatus = SKIPPED


if __name__ == "__main__":
    path = sys.argv[1]
    sys.argv = sys.argv[1:]
    sys.path.insert(0, os.path.dirname(os.path.abspath(path)))
    unittest.main = unittest_main
    runpy.run_path(path, run_name="__main__")
