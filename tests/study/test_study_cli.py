"""gonio study from the command line (docs/study.md): bad input exits 2 and
writes nothing; shards merged equal one unsharded run (time columns aside);
a run killed midway resumes without redoing its finished rows."""
import csv
import json
import os
import re
import signal
import subprocess
import tempfile
import time

import pytest

import child_procs  # tests/, on PYTHONPATH

BIN = os.path.join(os.environ.get("GONIO_BIN", "build/bin"), "gonio")
# Cheap and independent of the shared data: the embedded default material.
TINY = ["--materials", "default", "--plans", "ds4,ds3", "--models", "abc",
        "--scenes", "ideal,lab"]
TIME_COLUMNS = {"fit_wall_s", "fit_cpu_s"}


def gonio(*args, timeout=300):
    return subprocess.run([BIN, *args], capture_output=True, text=True, timeout=timeout)


def rows(path):
    with open(os.path.join(path, "results.csv"), newline="") as f:
        return list(csv.DictReader(f))


def without_times(table):
    return [{k: v for k, v in r.items() if k not in TIME_COLUMNS} for r in table]


@pytest.fixture
def tmp():
    with tempfile.TemporaryDirectory(prefix="study_cli_") as d:
        yield d


@pytest.mark.parametrize("args, needle", [
    (["--materials", "no-such-material"], "no-such-material"),
    (["--plans", "ds1,ds7"], "ds7"),
    (["--models", "abc,gpt"], "gpt"),
    (["--scenes", "no-such-scene"], "no-such-scene"),
    (["--shard", "3/2"], "3/2"),
    (["--shard", "0/2"], "0/2"),
    (["--shard", "one/2"], "one/2"),
    (["--jobs", "0"], "--jobs"),
    (["--bogus"], "usage"),
])
def test_bad_input_exits_2_and_writes_nothing(tmp, args, needle):
    out = os.path.join(tmp, "out")
    r = gonio("study", *TINY, *args, "--out", out)
    assert r.returncode == 2, (args, r.stderr)
    assert needle in r.stderr, r.stderr
    assert not os.path.exists(out)


def test_missing_out_and_bad_merge_exit_2(tmp):
    r = gonio("study", *TINY)
    assert r.returncode == 2 and "--out" in r.stderr
    r = gonio("study", "merge", os.path.join(tmp, "nothing-here"), "--out",
              os.path.join(tmp, "m"))
    assert r.returncode == 2 and "nothing-here" in r.stderr


def test_shards_merged_equal_one_run(tmp):
    one = os.path.join(tmp, "one")
    r = gonio("study", *TINY, "--jobs", "2", "--out", one)
    assert r.returncode == 0, r.stderr
    full = rows(one)
    assert len(full) == 4 and all(r["status"] == "ok" for r in full)
    # The shares are disjoint and together the job list.
    listed = [gonio("study", *TINY, "--shard", f"{i}/3", "--list").stdout.split()
              for i in (1, 2, 3)]
    assert sorted(sum(listed, [])) == sorted(gonio("study", *TINY, "--list").stdout.split())
    assert len(set(sum(listed, []))) == 4
    shards = []
    for i in (1, 2, 3):
        d = os.path.join(tmp, f"shard-{i}")
        r = gonio("study", *TINY, "--jobs", "1", "--shard", f"{i}/3", "--out", d)
        assert r.returncode == 0, r.stderr
        assert len(rows(d)) == len(listed[i - 1])  # one model: a row per job
        shards.append(d)
    merged = os.path.join(tmp, "merged")
    # An incomplete merge says what is missing and exits 1.
    r = gonio("study", "merge", *shards[:2], "--out", os.path.join(tmp, "part"))
    assert r.returncode == 1 and "missing" in r.stderr
    doc = json.load(open(os.path.join(tmp, "part", "results.json")))
    assert doc["complete"] is False
    assert len(doc["missing"]) == len(listed[2])
    r = gonio("study", "merge", *shards, "--out", merged)
    assert r.returncode == 0, r.stderr
    assert without_times(rows(merged)) == without_times(full)
    a = json.load(open(os.path.join(one, "results.json")))
    b = json.load(open(os.path.join(merged, "results.json")))
    assert a["study"] == b["study"] and b["complete"] is True
    strip = lambda rs: [{k: v for k, v in r.items() if k not in TIME_COLUMNS} for r in rs]
    assert strip(a["rows"]) == strip(b["rows"])
    # A complete study or merge carries its renderings, report and figures
    # (the grid of the first scene: the truth, then each fitted model); a
    # shard does not.
    for d in (one, merged):
        page = open(os.path.join(d, "report.html")).read()
        assert "<svg" in page and full[0]["material"] in page
        assert os.path.getsize(os.path.join(d, "plots", "pareto-full-" + full[0]["scene"] + ".png")) > 0
        grids = {m: os.path.join(d, "renders", m, "grid.png") for m in {r["material"] for r in full}}
        assert all(os.path.getsize(g) > 0 for g in grids.values()), os.listdir(d)
        first = [r for r in full if r["scene"] == full[0]["scene"]]
        renders = page[page.index('id="renders"'):page.index('id="rows"')]
        assert renders.count("<img") == len(grids)
        assert all(f'{r["plan"]}/{r["model"]}' in renders for r in first)
    assert not any(os.path.exists(os.path.join(d, "report.html")) for d in shards)
    assert not any(os.path.exists(os.path.join(d, "renders")) for d in shards)
    # A shard of another study is refused.
    other = os.path.join(tmp, "other")
    assert gonio("study", *TINY[:-2], "--scenes", "ideal", "--out", other).returncode == 0
    r = gonio("study", "merge", one, other, "--out", os.path.join(tmp, "bad"))
    assert r.returncode == 2 and "another study" in r.stderr
    # So is a rerun into a folder holding another study.
    r = gonio("study", *TINY[:-2], "--scenes", "lab", "--out", one)
    assert r.returncode == 2 and "other" in r.stderr


def test_killed_run_resumes_without_redoing_rows(tmp):
    out = os.path.join(tmp, "out")
    args = ["study", "--materials", "default", "--plans", "ds4,ds3,ds2", "--models", "abc",
            "--scenes", "ideal,lab", "--jobs", "1", "--out", out]
    p = subprocess.Popen([BIN, *args], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                         preexec_fn=child_procs.die_with_parent)
    jobs = os.path.join(out, "jobs")
    done = []
    deadline = time.time() + 240
    while time.time() < deadline and p.poll() is None:
        if os.path.isdir(jobs):
            done = [os.path.join(jobs, j, "abc.row.json") for j in sorted(os.listdir(jobs))
                    if os.path.exists(os.path.join(jobs, j, "abc.row.json"))]
        if done:
            break
        time.sleep(0.05)
    p.send_signal(signal.SIGKILL)
    p.wait()
    assert done, "no row was finished before the kill"
    before = {f: open(f, "rb").read() for f in done}
    # The worker died with its parent: the rerun gets every job's lock.
    r = gonio(*args[:-1], out)
    assert r.returncode == 0, r.stderr
    m = re.search(r"(\d+) finished, (\d+) to run", r.stderr)
    assert m and int(m.group(1)) >= len(done) and int(m.group(1)) + int(m.group(2)) == 6, r.stderr
    for f, data in before.items():
        assert open(f, "rb").read() == data, f + " was redone"
    assert len(rows(out)) == 6


def test_interrupted_run_stops_cleanly_and_resumes(tmp):
    """SIGINT (or SIGTERM) to gonio study: the job under way ends at a point
    boundary with its journal whole, no temporary file is left, the command
    says how to resume and exits 130; the rerun says it resumes and measures
    only what the journal lacks. On the ideal scene, which has no calibration
    to measure before the oop200k journal grows."""
    out = os.path.join(tmp, "out")
    args = ["study", "--materials", "default", "--plans", "ds4,oop200k", "--models", "abc",
            "--scenes", "ideal", "--jobs", "1", "--out", out]
    p = subprocess.Popen([BIN, *args], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                         text=True, preexec_fn=child_procs.die_with_parent)
    journal = os.path.join(out, "jobs", "default.ideal.oop200k", "samples.csv")
    deadline = time.time() + 240
    while time.time() < deadline and p.poll() is None:
        if os.path.exists(journal) and os.path.getsize(journal) > 4096:
            break
        time.sleep(0.01)
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=240)
    assert p.returncode == 130, err
    assert "run the same command again to resume" in err
    assert "1 stopped at a point with their journals kept" in err, err
    left = [os.path.join(d, f) for d, _, fs in os.walk(out) for f in fs if ".tmp." in f]
    assert left == []
    with open(journal) as f:
        measured = sum(1 for _ in f) - 1
    assert 0 < measured < 190038
    assert not os.path.exists(os.path.join(out, "jobs", "default.ideal.oop200k", "abc.row.json"))
    r = gonio(*args)
    assert r.returncode == 0, r.stderr
    assert "resuming: 0 of 2 jobs done, 1 started" in r.stderr, r.stderr
    assert len(rows(out)) == 2
