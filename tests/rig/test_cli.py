"""gonio-sim's command line: --check resolves the scene without serving,
bad input exits 2 with a message on stderr and nothing on stdout."""
import os
import shutil
import tempfile

from conftest import gonio_bin, tg


def run(*args):
    """gonio-sim with args (under GONIO_WRAP, failing on a valgrind error)."""
    logs = tempfile.mkdtemp(prefix="rig-cli")
    try:
        return tg.run_wrapped([os.path.join(gonio_bin(), "gonio-sim"), *args], logs)
    finally:
        shutil.rmtree(logs, ignore_errors=True)


def test_check_prints_the_resolved_setup():
    r = run("--check", "--time-scale", "25", "--steps-per-deg", "200")
    assert r.returncode == 0, r.stderr
    out = r.stdout
    assert "scene ideal" in out and "time scale 25" in out and "steps per degree 200" in out
    # configs/rigs/default.yaml: sample [-90, 90], arm [-170, 170], azimuth present.
    assert "axis sample (slave 1): limits [-90, 90] deg" in out
    assert "axis arm (slave 2): limits [-170, 170] deg" in out
    assert "azimuth (slave 4)" in out
    assert "RTU line" not in out and "TCP latency" not in out  # free unless asked


def test_check_prints_the_line_costs():
    r = run("--check", "--baud", "19200", "--tcp-latency", "2.5")
    assert r.returncode == 0, r.stderr
    assert "RTU line 19200 baud" in r.stdout and "TCP latency 2.5 ms" in r.stdout


def test_check_prints_the_simulated_clock():
    r = run("--check", "--clock", "simulated")
    assert r.returncode == 0, r.stderr
    assert "clock simulated" in r.stdout and "time scale" not in r.stdout


def test_bad_input_exits_2():
    for args in (["--time-scale", "0"], ["--clock", "fast"],
                 ["--clock", "simulated", "--time-scale", "20"],
                 ["--steps-per-deg", "x"], ["--tcp", "localhost"],
                 ["--scene", "no-such-scene"], ["--stall", "9:10"], ["--overload", "1:500"],
                 ["--baud", "0"], ["--baud", "9600.5"], ["--tcp-latency", "-1"],
                 ["--bogus"], ["extra"]):
        r = run(*args)
        assert r.returncode == 2, (args, r.returncode, r.stderr)
        assert r.stdout == "", args
        assert r.stderr.strip() and "gonio-sim" in r.stderr, args
