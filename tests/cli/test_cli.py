"""What an operator types and reads: --version everywhere, gonio help CMD, did-you-mean, one error style;
gonio plan's summary, durations, rig file and blind zone; gonio results as a
table; refusals of report, export and study; goniod --check's group and host;
gonio-sim's announcement (through a pty, as a person sees it); the man pages
against --help."""
import csv
import grp
import io
import json
import os
import pty
import re
import select
import shutil
import signal
import subprocess
import tempfile
import time

import pytest

import child_procs  # tests/, on PYTHONPATH

BIN = os.environ.get("GONIO_BIN", "build/bin")
GONIO = os.path.join(BIN, "gonio")
GONIOD = os.path.join(BIN, "goniod")
SIM = os.path.join(BIN, "gonio-sim")
SOURCE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
CONFIG = os.environ.get("GONIO_CONFIG", os.path.join(SOURCE, "configs"))
VERSION = re.search(r"project\(gonio VERSION (\S+)",
                    open(os.path.join(SOURCE, "CMakeLists.txt")).read()).group(1)


def run(*args, cwd=None, timeout=300):
    return subprocess.run(list(args), capture_output=True, text=True, cwd=cwd, timeout=timeout)


def gonio(*args, cwd=None):
    return run(GONIO, *args, cwd=cwd)


@pytest.fixture
def tmp():
    with tempfile.TemporaryDirectory(prefix="cli_") as d:
        yield d


def rig_file(folder, blind):
    """The default rig profile copied under another file name, its blind
    zone changed: the name inside stays 'default'."""
    text = open(os.path.join(CONFIG, "rigs", "default.yaml")).read()
    text, n = re.subn(r"(?m)^blind_deg: *\d+", "blind_deg: %d" % blind, text)
    assert n == 1
    path = os.path.join(folder, "rig%d.yaml" % blind)
    with open(path, "w") as f:
        f.write(text)
    return path


# --- item 3: conventions ---------------------------------------------------

@pytest.mark.parametrize("prog, name", [(GONIO, "gonio"), (GONIOD, "goniod"), (SIM, "gonio-sim")])
def test_version(prog, name):
    r = run(prog, "--version")
    assert r.returncode == 0, r.stderr
    assert r.stdout == "%s %s\n" % (name, VERSION)


@pytest.mark.parametrize("cmd", ["plan", "results", "report", "plot", "export", "study",
                                 "status", "fit", "render"])
def test_help_cmd_equals_cmd_help(cmd):
    a, b = gonio("help", cmd), gonio(cmd, "--help")
    assert a.returncode == b.returncode == 0, (a.stderr, b.stderr)
    assert a.stdout == b.stdout
    assert a.stdout.startswith("usage: gonio " + cmd), a.stdout[:80]


@pytest.mark.parametrize("typo, guess", [("captur", "capture"), ("stauts", "status"),
                                         ("reslts", "results"), ("pln", "plan")])
def test_did_you_mean(typo, guess):
    r = gonio(typo)
    assert r.returncode == 2
    first = r.stderr.splitlines()[0]
    assert first == "gonio: unknown command '%s'; did you mean '%s'?" % (typo, guess)


def test_no_guess_for_another_word():
    r = gonio("frobnicate")
    assert r.returncode == 2
    assert r.stderr.splitlines()[0] == "gonio: unknown command 'frobnicate'"


@pytest.mark.parametrize("args, first", [
    (["plot"], "gonio plot: a figure is required (slices, pareto or bars)"),
    (["results"], "gonio results: at least one capture directory is required"),
    (["plan"], "gonio plan: a plan NAME or FILE is required"),
    (["plot", "slices", "--bogus"], "gonio plot: unrecognized option '--bogus'"),
    (["report", "--bogus"], "gonio report: unrecognized option '--bogus'"),
    (["export", "merl", "--bogus"], "gonio export: unrecognized option '--bogus'"),
    (["results", "--bogus", "x"], "gonio results: unknown option '--bogus'"),
    (["plan", "ds4", "--bogus"], "gonio plan: unknown option '--bogus'"),
])
def test_usage_errors_one_line_then_usage(args, first):
    r = gonio(*args)
    assert r.returncode == 2
    lines = r.stderr.splitlines()
    assert lines[0] == first, r.stderr
    assert any(l.startswith("usage: gonio") for l in lines[1:]), r.stderr


def test_capture_offline_help_names_every_material_kind():
    r = gonio("capture", "--offline", "--help")
    assert r.returncode == 0
    for kind in ("nbrdf:", "merl:", "abc:", "sgd:", "builtin:", "spectral:", "default"):
        assert kind in r.stdout, kind


def test_gonio_sim_says_what_it_serves_on_a_terminal():
    """Started by hand with no arguments: stdout's first line stays the pty
    path (programs read it), and the terminal is told what is served."""
    pid, fd = pty.fork()
    if pid == 0:
        child_procs.die_with_parent()
        os.execv(SIM, [SIM])
    out = b""
    deadline = time.monotonic() + 20
    try:
        while b"Ctrl-C stops" not in out and time.monotonic() < deadline:
            if select.select([fd], [], [], 0.5)[0]:
                try:
                    out += os.read(fd, 4096)
                except OSError:
                    break
    finally:
        os.kill(pid, signal.SIGTERM)
        os.waitpid(pid, 0)
        os.close(fd)
    lines = out.decode().replace("\r", "").splitlines()
    assert re.fullmatch(r"/dev/pts/\d+", lines[0]), lines
    assert lines[1] == ("gonio-sim: Modbus RTU on %s (scene ideal, material builtin:nylon, "
                        "rig default, time scale 1); Ctrl-C stops" % lines[0]), lines


def read_lines(fd, n, timeout=20):
    """Up to n lines from fd, waiting at most timeout seconds (a program that
    never writes them fails the test instead of hanging it)."""
    data, deadline = b"", time.monotonic() + timeout
    while data.count(b"\n") < n and time.monotonic() < deadline:
        if select.select([fd], [], [], 0.5)[0]:
            chunk = os.read(fd, 4096)
            if not chunk:
                break
            data += chunk
    return data.decode().splitlines(keepends=True) + [""] * n


def test_gonio_sim_stdout_is_only_the_path():
    p = subprocess.Popen([SIM, "--tcp", "127.0.0.1:0"], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, preexec_fn=child_procs.die_with_parent)
    try:
        first, second = read_lines(p.stdout.fileno(), 2)[:2]
        announce = read_lines(p.stderr.fileno(), 1)[0]
    finally:
        p.terminate()
        p.wait(timeout=20)
    assert re.fullmatch(r"/dev/pts/\d+\n", first)
    port = re.fullmatch(r"tcp 127\.0\.0\.1:(\d+)\n", second).group(1)
    assert "Modbus RTU on %s and Modbus TCP on 127.0.0.1:%s" % (first.strip(), port) in announce


# --- man pages: one source, checked against --help -------------------------

def long_options(text):
    return set(re.findall(r"(?<![\w-])--([a-z][a-z0-9-]*)", text)) - {"help"}


def man_text(name):
    """The roff source with its escapes undone enough to find options."""
    return open(os.path.join(SOURCE, "docs", "man", name)).read().replace("\\-", "-")


@pytest.mark.parametrize("prog, page", [(GONIOD, "goniod.8"), (SIM, "gonio-sim.1")])
def test_man_page_names_every_option(prog, page):
    opts = long_options(run(prog, "--help").stdout)
    assert opts, "no options in --help"
    missing = opts - long_options(man_text(page))
    assert not missing, "%s lacks %s" % (page, sorted(missing))


def test_gonio_man_page_has_every_command_and_its_options():
    page = man_text("gonio.1")
    sections = dict(re.findall(r"(?m)^\.SS gonio ([a-z-]+)(.*?)(?=^\.SS|^\.SH)",
                               page, re.S) or [])
    listed = re.findall(r"(?m)^  ([a-z][a-z-]+) ", gonio("--help").stdout)
    assert len(listed) >= 16
    for cmd in listed:
        assert cmd in sections, "gonio.1 has no section for %s" % cmd
        missing = long_options(gonio(cmd, "--help").stdout) - long_options(sections[cmd])
        assert not missing, "gonio.1, %s: %s" % (cmd, sorted(missing))


def test_goniod_yaml_page_names_every_key():
    keys = re.findall(r"(?m)^\| `([a-z_.]+)`", open(os.path.join(SOURCE, "docs",
                                                                   "goniod.md")).read())
    page = man_text("goniod.yaml.5")
    missing = {k for k in keys if k.split(".")[-1] not in page}
    assert len(keys) > 20 and not missing, sorted(missing)


# --- item 4: gonio plan ------------------------------------------------------

def test_plan_inplane_1deg_pool():
    """The adaptive pool: every reachable in-plane pair on a 1-degree grid
    (81 x 161 minus the 719 in the 5-degree blind zone), declared adaptive,
    kept as written (its first pairs theta_i 0, theta_r -80, -79, ...)."""
    r = gonio("plan", "inplane-1deg", "--json")
    assert r.returncode == 0, r.stderr
    doc = json.loads(r.stdout)
    assert doc["count"] == 81 * 161 - 719 == 12322
    assert doc["order"] == "adaptive"
    assert [(p["theta_i"], p["theta_r"]) for p in doc["pairs"][:3]] == [(0, -80), (0, -79),
                                                                       (0, -78)]
    assert len({(p["theta_i"], p["theta_r"]) for p in doc["pairs"]}) == 12322


def test_capture_adaptive_offline(tmp):
    """--order adaptive: progress lines carry the policy's prediction (no
    bar: the pool is not measured whole), marked rough below 40 samples
    (where its calibration is poor), the summary its stop and figures; its
    ABC model weighs the samples by their domain share, and gonio fit of the
    directory writes the same file byte for byte (--weights none another),
    and a latent fit of them is weighted too (the weights line and key);
    --budget outside the adaptive order, or not a positive number, exits 2
    with nothing written."""
    out = os.path.join(tmp, "ad")
    r = gonio("capture", "--offline", "--scene", "ideal", "--plan", "ds2", "--order", "adaptive",
              "--stop", "all", "--budget", "2", "--out", out)
    assert r.returncode == 0, r.stderr
    assert "(pool of 160)" in r.stderr
    lines = re.findall(r"capture: (\d+) points .*predicted error now \d\.\d{3}( \(rough: few "
                       r"samples\))?", r.stderr)
    assert {int(n) < 40 for n, _ in lines} == {True, False}, r.stderr
    assert all((int(n) < 40) == bool(rough) for n, rough in lines), r.stderr
    assert re.search(r"adaptive: stopped \(budget\) after \d+ samples; predicted full-domain "
                     r"log error of abc \d\.\d{4}", r.stdout), r.stdout
    with open(os.path.join(out, "results.json")) as f:
        res = json.load(f)
    assert res["rig_time_s"] <= 120
    assert res["adaptive"]["prediction_rough"] is (res["samples"] < 40)
    with open(os.path.join(out, "abc.model"), "rb") as f:
        captured = f.read()
    assert b"\nweights each sample's share of the full domain\n" in captured
    for weights, same in ((), True), (("--weights", "domain"), True), (("--weights", "none"), False):
        refit = os.path.join(tmp, "refit.model")
        r = gonio("fit", out, "--model", "abc", "--quiet", "-o", refit, *weights)
        assert r.returncode == 0, r.stderr
        assert ("weights    each sample's share of the full domain (%s)"
                % ("--weights domain" if weights else "an adaptive capture's samples")
                in r.stdout) is same, r.stdout
        with open(refit, "rb") as f:
            assert (f.read() == captured) is same, weights
    for weights, weighted in ((), True), (("--weights", "none"), False):  # latent weighs too
        refit = os.path.join(tmp, "refit-latent.model")
        r = gonio("fit", out, "--model", "latent", "--quiet", "-o", refit, *weights)
        assert r.returncode == 0, r.stderr
        assert ("weights    each sample's share" in r.stdout) is weighted, r.stdout
        with open(refit, "rb") as f:
            assert (b"\nweights each sample's share of the full domain\n" in f.read()) is weighted
    r = gonio("fit", out, "--model", "abc", "--weights", "some")
    assert r.returncode == 2 and "--weights 'some': use domain or none" in r.stderr, r.stderr
    for args, needle in ((("--budget", "0.5"), "--budget 0.5: only the adaptive order"),
                         (("--stop-target", "0.05"), "--stop-target 0.05: only the adaptive"),
                         (("--order", "adaptive", "--budget", "soon"), "--budget 'soon'"),
                         (("--order", "adaptive", "--stop-target", "0"), "--stop-target '0'")):
        bad = os.path.join(tmp, "bad")
        r = gonio("capture", "--offline", "--scene", "ideal", "--plan", "ds2", "--out", bad,
                  *args)
        assert r.returncode == 2, (args, r.stderr)
        assert needle in r.stderr, (args, r.stderr)
        assert not os.path.exists(bad), args


def test_plan_summary_first_and_alone():
    full = gonio("plan", "ds1")
    assert full.returncode == 0, full.stderr
    lines = full.stdout.splitlines()
    assert lines[0].startswith("plan ds1 (") and ", rig default, order travel" in lines[0]
    assert lines[1] == "count: 912 pairs"
    # the total in minutes and seconds and in seconds, as --json has it
    total = json.loads(gonio("plan", "ds1", "--json").stdout)["estimate"]["total_s"]
    words = f"{round(total) // 60} min {round(total) % 60} s"
    assert lines[2].startswith(f"estimate: total {words} ({total:.1f} s)"), lines[2]
    # what auto-ranging could add: every point at the default rig's longest
    # rung (2 s, not 0.05 s) and a dark frame at each of its seven rungs
    rungs = 0.001 + 0.003125 + 0.0125 + 0.05 + 0.2 + 0.8 + 2.0
    up = total + 912 * (2.0 - 0.05) + rungs
    assert lines[3].startswith("with auto-ranging (a detector of counts): up to ") and \
        lines[3].endswith(f"({up:.1f} s), every point at the longest integration"), lines[3]
    summary = gonio("plan", "ds1", "--summary")
    assert summary.returncode == 0
    assert full.stdout.startswith(summary.stdout)
    assert len(summary.stdout.splitlines()) == 5  # no table
    assert len(lines) == 5 + 1 + 912


def test_plan_on_a_scene_of_counts(tmp):
    """A dry run measures nothing, so a scene whose detector gives counts
    (lab) needs no calibration to be planned: its estimate is the rig's
    fixed integration (the material is not known before the first
    reading) with the bound auto-ranging could reach, as the plan's own;
    a capture of it is still refused without one."""
    for order in ((), ("--order", "adaptive")):
        fixed = gonio("plan", "ds3", "--summary", *order)
        lab = gonio("plan", "ds3", "--scene", "lab", "--summary", *order)
        assert lab.returncode == 0, lab.stderr
        lines = lab.stdout.splitlines()
        assert lines[1:] == fixed.stdout.splitlines()[1:], (order, lab.stdout)
        assert lines[3].startswith("with auto-ranging (a detector of counts): up to ")
    doc = json.loads(gonio("plan", "ds3", "--scene", "lab", "--json").stdout)
    assert doc["estimate"] == json.loads(gonio("plan", "ds3", "--json").stdout)["estimate"]
    out = os.path.join(tmp, "cap")
    r = gonio("capture", "--offline", "--scene", "lab", "--plan", "ds3", "--out", out)
    assert r.returncode == 2 and "gives counts and the capture names no calibration" \
        in r.stderr, r.stderr
    assert not os.path.exists(out)


def test_plan_hours():
    r = gonio("plan", "oop200k", "--summary")
    assert r.returncode == 0, r.stderr
    # the value is test_order's; here, that hours read as hours
    m = re.search(r"estimate: total (\d+) h (\d+) min (\d+) s \((\d+\.\d) s\)", r.stdout)
    assert m, r.stdout
    total = round(float(m.group(4)))
    assert total > 36000
    assert [int(g) for g in m.groups()[:3]] == [total // 3600, total % 3600 // 60, total % 60]
    assert " min " not in re.sub(r"\d+ h \d+ min \d+ s|\d+ min \d+ s", "", r.stdout)


def test_plan_names_a_rig_file_by_its_file(tmp):
    path = rig_file(tmp, 5)
    r = gonio("plan", "ds3", "--rig", path, "--summary")
    assert r.returncode == 0, r.stderr
    assert ", rig %s, order" % path in r.stdout.splitlines()[0]
    doc = json.loads(gonio("plan", "ds3", "--rig", path, "--json").stdout)
    assert doc["rig"] == {"name": "default", "file": path}
    doc = json.loads(gonio("plan", "ds3", "--json").stdout)
    assert doc["rig"] == {"name": "default",
                          "file": os.path.join(CONFIG, "rigs", "default.yaml")}


def test_plan_on_a_wider_blind_zone(tmp):
    """Plans carry blind: 5; a rig that cannot see within 10 deg runs them
    without the pairs it cannot reach, and says how many."""
    path = rig_file(tmp, 10)
    for plan, kept, left in (("ds1", 863, 49), ("ds3", 48, 4)):
        r = gonio("plan", plan, "--rig", path, "--summary")
        assert r.returncode == 0, r.stderr
        assert "count: %d pairs" % kept in r.stdout
        assert "(%d pairs left out: in the rig's 10 deg blind zone)" % left in r.stdout
        pairs = json.loads(gonio("plan", plan, "--rig", path, "--json").stdout)["pairs"]
        assert len(pairs) == kept
        assert all(abs(p["theta_i"] + p["theta_r"]) >= 10 - 1e-9 for p in pairs)


def test_plan_listed_pair_in_the_blind_zone_still_refused(tmp):
    path = os.path.join(tmp, "p.yaml")
    with open(path, "w") as f:
        f.write("pairs:\n  - [30, -60]\n  - [30, -22]\n")
    r = gonio("plan", path, "--rig", rig_file(tmp, 10))
    assert r.returncode == 2
    assert r.stdout == ""
    assert r.stderr.startswith("gonio plan: %s:3:5: pair (theta_i 30, theta_r -22)" % path)
    assert "inside the 10 deg blind zone" in r.stderr


# --- item 6: gonio results --------------------------------------------------

def fake_capture(folder, name, plan, model, rig_s, scene="ideal", errors=True, status=None,
                 truth=None):
    d = os.path.join(folder, name)
    os.makedirs(d)
    doc = {"plan": plan, "material": "nbrdf:nylon", "model": model, "samples": 6,
           "rig_time_s": rig_s, "fit_time_s": 0.25, "converged": True,
           "errors": {"plan": {"log": 0.01, "rel_rmse": 0.02, "n": 6}}}
    if errors:
        doc["errors"]["inplane"] = {"log": 0.0602, "rel_rmse": 2.3065, "n": 9218}
        doc["errors"]["full"] = {"log": 0.0588, "rel_rmse": 2.3412, "n": 923870}
    if status:
        doc["fit_status"] = {"status": status, "findings": ""}
    if truth:
        doc["truth"] = truth
    with open(os.path.join(d, "results.json"), "w") as f:
        json.dump(doc, f)
    if scene:
        with open(os.path.join(d, "setup.json"), "w") as f:
            json.dump({"scene": {"name": scene}, "material": "nbrdf:nylon"}, f)
    return d


def test_results_table(tmp):
    dirs = [fake_capture(tmp, "a", "ds4", "abc", 1199.9999),
            fake_capture(tmp, "b-longer-name", "inplane-full", "latent", 125578.2, scene="lab",
                         status="ok", truth="nbrdf:nylon"),
            fake_capture(tmp, "c", "ds4", "mlp", 15.1, scene=None, errors=False)]
    r = gonio("results", *dirs)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert len(lines) == 4
    head = lines[0].split()
    assert head[:6] == ["directory", "plan", "scene", "material", "model", "samples"]
    rows = [l.split() for l in lines[1:]]
    assert rows[0][:8] == [dirs[0], "ds4", "ideal", "nbrdf:nylon", "abc", "6", "0:20:00",
                           "0.2500"]
    assert rows[1][:9] == [dirs[1], "inplane-full", "lab", "nbrdf:nylon", "latent", "6",
                           "34:52:58", "0.2500", "ok"]
    assert rows[2][:9] == [dirs[2], "ds4", "-", "nbrdf:nylon", "mlp", "6", "0:00:15", "0.2500",
                           "-"]
    # the plan-domain log error, which every capture has, then the truth errors
    assert rows[2][9:] == ["0.0100"] + ["-"] * 4
    assert rows[0][9:] == ["0.0100", "0.0602", "2.3065", "0.0588", "2.3412"]
    # aligned: every column starts at the same place on every line
    for word in ("plan", "scene", "material", "samples"):
        col = lines[0].index(word if word != "samples" else "samples")
        if word in ("plan", "scene", "material"):
            assert all(l[col - 2:col] == "  " and l[col] != " " for l in lines[1:]), word
        else:
            end = col + len("samples")
            assert all(l[end - 1] == "6" and l[end] == " " for l in lines[1:])
    assert len({len(l.rstrip()) for l in lines}) == 1


def test_results_json_and_csv(tmp):
    dirs = [fake_capture(tmp, "a", "ds4", "abc", 1199.9999),
            fake_capture(tmp, "c", "ds4", "mlp", 15.1, scene=None, errors=False)]
    doc = json.loads(gonio("results", "--json", *dirs).stdout)
    assert [d["dir"] for d in doc] == dirs
    assert doc[0]["rig"] == 1199.9999 and doc[0]["scene"] == "ideal"
    assert doc[1]["scene"] is None and doc[1]["full_log"] is None
    assert doc[1]["status"] is None
    rows = list(csv.DictReader(io.StringIO(gonio("results", "--csv", *dirs).stdout)))
    assert [r["dir"] for r in rows] == dirs
    assert float(rows[0]["rig"]) == 1199.9999
    assert rows[1]["full_log"] == "" and rows[1]["scene"] == ""
    assert float(rows[0]["inplane_rel"]) == 2.3065


def test_results_format(tmp):
    d = fake_capture(tmp, "a", "ds4", "abc", 1199.9999)
    r = gonio("results", "--format", "%dir %plan %model %rig %full_log 100%%", d)
    assert r.returncode == 0, r.stderr
    assert r.stdout == "%s ds4 abc 1200 0.0588 100%%\n" % d
    r = gonio("results", "--format", "%plna", d)
    assert r.returncode == 2
    assert r.stdout == ""
    assert r.stderr.startswith("gonio results: --format: unknown placeholder '%plna'")


def test_results_missing_file(tmp):
    good = fake_capture(tmp, "a", "ds4", "abc", 10)
    missing = os.path.join(tmp, "nothing")
    r = gonio("results", good, missing)
    assert r.returncode == 2
    assert r.stderr == "gonio results: %s/results.json: no such file\n" % missing
    assert good in r.stdout  # the good row is still printed


# --- the small items ---------------------------------------------------------

@pytest.fixture(scope="module")
def study():
    with tempfile.TemporaryDirectory(prefix="cli_study_") as d:
        out = os.path.join(d, "st")
        r = gonio("study", "--materials", "default", "--plans", "ds4", "--models", "abc",
                  "--scenes", "ideal", "--out", out)
        assert r.returncode == 0, r.stderr
        yield out


def test_report_unknown_slices_plan_is_a_usage_error(study, tmp):
    out = os.path.join(tmp, "r.html")
    r = gonio("report", study, "--slices", "ds4,ds9", "--out", out, "--no-plots")
    assert r.returncode == 2
    assert r.stderr == "gonio report: --slices: the study has no plan 'ds9'\n"
    assert not os.path.exists(out)
    r = gonio("report", study, "--slices", "ds4", "--out", out, "--no-plots", "--quiet")
    assert r.returncode == 0, r.stderr
    assert "slices-default-ideal-ds4" in open(out).read()


def test_report_out_must_be_html(study, tmp):
    out = os.path.join(tmp, "r.pdf")
    r = gonio("report", study, "--out", out, "--no-plots")
    assert r.returncode == 2
    assert r.stderr.startswith("gonio report: --out '%s':" % out)
    assert not os.path.exists(out)


def test_export_requires_binary(tmp):
    out = os.path.join(tmp, "x.txt")
    r = gonio("export", "merl", "--material", "default", "-o", out)
    assert r.returncode == 2
    assert r.stderr.startswith("gonio export: -o '%s':" % out)
    assert not os.path.exists(out)


def test_study_takes_a_plan_file(tmp):
    plan = os.path.join(tmp, "six.yaml")
    shutil.copy(os.path.join(CONFIG, "plans", "ds4.yaml"), plan)
    out = os.path.join(tmp, "st")
    r = gonio("study", "--materials", "default", "--plans", "ds4," + plan, "--models", "abc",
              "--scenes", "ideal", "--out", out)
    assert r.returncode == 0, r.stderr
    with open(os.path.join(out, "results.csv"), newline="") as f:
        rows = {r["plan"]: r for r in csv.DictReader(f)}
    assert set(rows) == {"ds4", "six"}
    # the same six pairs captured the same way: the same answer
    assert rows["six"]["plan_points"] == rows["ds4"]["plan_points"] == "6"
    assert rows["six"]["full_log"] == rows["ds4"]["full_log"]
    spec = json.load(open(os.path.join(out, "study.json")))["plans"]
    assert plan in json.dumps(spec)
    bad = gonio("study", "--materials", "default", "--plans", os.path.join(tmp, "no.yaml"),
                "--models", "abc", "--scenes", "ideal", "--out", os.path.join(tmp, "x"))
    assert bad.returncode == 2 and "no.yaml" in bad.stderr


def test_fit_mlp_spectral_reads_a_spectral_captures_spectra(tmp):
    """gonio fit DIR --model mlp-spectral takes DIR/spectra.csv (it used to
    read DIR/samples.csv, the RGB journal, and refuse its header)."""
    cap = os.path.join(tmp, "spec")
    r = gonio("capture", "--offline", "--scene", "spectral-cyan", "--plan", "ds4", "--out", cap,
              "--quiet")
    assert r.returncode == 0, r.stderr
    with open(os.path.join(cap, "spectra.csv")) as f:
        rows = len(f.read().splitlines()) - 1
    r = gonio("fit", cap, "--model", "mlp-spectral", "--epochs", "50", "--quiet")
    assert r.returncode == 0, r.stderr
    assert re.search(r"(?m)^samples +%d \(%s/spectra.csv\)" % (rows, re.escape(cap)), r.stdout), \
        r.stdout
    assert os.path.exists(os.path.join(cap, "mlp-spectral.model"))


# --- goniod --check: what would fail at start is refused up front -----------

GOOD = ("rig: default\ndriver:\n  kind: sim\n  scene: ideal\n"
        "capture_root: caps\nsocket:\n  path: run/g.sock\n")


def check(tmp, text):
    path = os.path.join(tmp, "c.yaml")
    with open(path, "w") as f:
        f.write(text)
    return path, run(GONIOD, "--config", path, "--check")


def test_check_group_must_exist(tmp):
    name = "gonio-no-such-group"
    with pytest.raises(KeyError):
        grp.getgrnam(name)
    path, r = check(tmp, GOOD + "  group: %s\n" % name)
    assert r.returncode == 2
    assert r.stderr.startswith("goniod: %s:8:10: key 'group': group '%s' does not exist"
                               % (path, name))
    mine = grp.getgrgid(os.getgid()).gr_name
    path, r = check(tmp, GOOD + "  group: %s\n" % mine)
    assert r.returncode == 0, r.stderr


def test_check_tcp_host_must_be_an_address(tmp):
    tcp = ("rig: default\ndriver:\n  kind: modbus-tcp\n  host: localhost\n  port: 1502\n"
           "  slaves: {sample: 1, arm: 2, detector: 3, azimuth: 4}\n"
           "capture_root: caps\nsocket:\n  path: run/g.sock\n")
    path, r = check(tmp, tcp)
    assert r.returncode == 2
    assert r.stderr.startswith("goniod: %s:4:9: key 'host': not a numeric IPv4 address "
                               "(value 'localhost'" % path)
    path, r = check(tmp, tcp.replace("localhost", "127.0.0.1"))
    assert r.returncode == 0, r.stderr
