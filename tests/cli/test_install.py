"""make install and make package (docs/install.md): the
installed gonio runs from outside the source tree with the source tree's
configs hidden; the README's goniod command works against the installed
config; the .deb holds the unit, sysusers.d and tmpfiles.d files and its
postinst creates the gonio user and group."""
import grp
import os
import re
import shutil
import subprocess
import tempfile

import pytest

BUILD = os.path.abspath(os.environ.get("GONIO_BUILD", "build"))
SOURCE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")


def run(*args, env=None, cwd="/", timeout=600):
    return subprocess.run(list(args), capture_output=True, text=True, env=env, cwd=cwd,
                          timeout=timeout)


def clean_env():
    """No GONIO_* variable: the installed tree must find its own files."""
    return {k: v for k, v in os.environ.items() if not k.startswith("GONIO_")}


@pytest.fixture(scope="module")
def dest():
    with tempfile.TemporaryDirectory(prefix="cli_install_") as d:
        env = dict(os.environ, DESTDIR=d)
        r = run("cmake", "--install", BUILD, env=env, cwd=SOURCE)
        assert r.returncode == 0, r.stderr
        yield d


def test_layout(dest):
    for path in ("usr/bin/gonio", "usr/bin/goniod", "usr/bin/gonio-sim",
                 "etc/gonio/goniod.yaml", "etc/gonio/plans/ds3.yaml", "etc/gonio/rigs/default.yaml",
                 "etc/gonio/scenes/ideal.yaml", "etc/gonio/render/default.yaml",
                 "etc/gonio/models/latent-decoder.gld",
                 "usr/share/gonio/models/latent-decoder.gld",
                 "usr/lib/systemd/system/goniod.service", "usr/lib/sysusers.d/gonio.conf",
                 "usr/lib/tmpfiles.d/gonio.conf", "usr/share/man/man1/gonio.1",
                 "usr/share/man/man8/goniod.8", "usr/share/man/man5/goniod.yaml.5",
                 "usr/share/man/man1/gonio-sim.1", "usr/share/doc/gonio/goniod.md",
                 "usr/share/doc/gonio/python.md") + PYTHON_FILES:
        assert os.path.exists(os.path.join(dest, path)), path
    assert os.path.islink(os.path.join(dest, "etc/gonio/models"))
    sysusers = open(os.path.join(dest, "usr/lib/sysusers.d/gonio.conf")).read()
    assert re.search(r"(?m)^g gonio ", sysusers) and re.search(r"(?m)^u gonio ", sysusers)
    tmpfiles = open(os.path.join(dest, "usr/lib/tmpfiles.d/gonio.conf")).read()
    for folder in ("/run/goniod", "/var/lib/gonio", "/var/lib/gonio/captures"):
        assert re.search(r"(?m)^d %s 0750 gonio gonio" % re.escape(folder), tmpfiles), folder
    unit = open(os.path.join(dest, "usr/lib/systemd/system/goniod.service")).read()
    assert "User=gonio\n" in unit and "ExecStart=/usr/bin/goniod --config /etc/gonio/goniod.yaml" in unit


# The Python client (docs/python.md): its modules and its model library.
PYTHON_DIR = "usr/lib/python3/dist-packages/gonio"
PYTHON_FILES = tuple(PYTHON_DIR + "/" + f for f in (
    "__init__.py", "client.py", "capture.py", "model.py", "_arrays.py", "libgonio_model.so"))


def test_installed_python_client(dest):
    """The installed package, with no GONIO_* variable, reads a capture the
    installed gonio made and evaluates its model through the installed
    libgonio_model.so: the plan error results.json holds."""
    out = os.path.join(dest, "cap-py")
    cap = run(os.path.join(dest, "usr/bin/gonio"), "capture", "--offline", "--scene", "ideal",
              "--plan", "ds4", "--quiet", "--out", out, env=clean_env())
    assert cap.returncode == 0, cap.stderr
    script = """
import math, sys, gonio
assert gonio.__file__.startswith(sys.argv[2]), gonio.__file__
cap = gonio.read_capture(sys.argv[1])
fitted = gonio.Model(cap.model_file).eval_inplane(cap.samples["theta_i"], cap.samples["theta_r"])
terms = [abs(math.log1p(p * math.cos(math.radians(ti))) - math.log1p(f * math.cos(math.radians(ti))))
         for ti, pr, fr in zip(cap.samples["theta_i"], fitted, cap.samples["rgb"])
         for p, f in zip(pr, fr)]
print(repr(sum(terms) / len(terms)), repr(cap.results["errors"]["plan"]["log"]))
"""
    env = dict(clean_env(), PYTHONPATH=os.path.join(dest, "usr/lib/python3/dist-packages"))
    r = run("python3", "-c", script, out, os.path.join(dest, PYTHON_DIR), env=env)
    assert r.returncode == 0, r.stderr
    mine, theirs = map(float, r.stdout.split())
    assert abs(mine - theirs) < 1e-9, r.stdout


def installed_runs(dest, out):
    """What the installed gonio does from /, with no GONIO_* variable."""
    gonio = os.path.join(dest, "usr/bin/gonio")
    env = clean_env()
    plan = run(gonio, "plan", "ds3", "--summary", env=env)
    cap = run(gonio, "capture", "--offline", "--scene", "ideal", "--plan", "ds4", "--model",
              "latent", "--quiet", "--out", out, env=env)
    return plan, cap


def check_installed(dest, plan, cap, out):
    assert plan.returncode == 0, plan.stderr
    assert plan.stdout.splitlines()[0].startswith(
        "plan ds3 (%s/etc/gonio/plans/ds3.yaml), rig default" % dest), plan.stdout
    assert "count: 52 pairs" in plan.stdout
    assert cap.returncode == 0, cap.stderr  # the latent decoder found in /usr/share/gonio
    assert os.path.exists(os.path.join(out, "latent.model"))


def test_installed_gonio_reads_installed_configs(dest):
    out = os.path.join(dest, "cap1")
    plan, cap = installed_runs(dest, out)
    check_installed(dest, plan, cap, out)


def test_installed_gonio_without_the_source_tree(dest):
    """The same with the source tree's configs/ hidden by an empty tmpfs in
    a private mount namespace: nothing may come from there."""
    if os.geteuid() != 0 or not shutil.which("unshare"):
        pytest.skip("needs root and unshare to hide the source tree's configs")
    probe = run("unshare", "-m", "--propagation", "private", "true")
    if probe.returncode != 0:
        pytest.skip("no mount namespace here: " + probe.stderr.strip()[:100])
    out = os.path.join(dest, "cap2")
    configs = os.path.realpath(os.path.join(SOURCE, "configs"))
    gonio = os.path.join(dest, "usr/bin/gonio")
    script = ('mount -t tmpfs none "$1" && test -z "$(ls -A "$1")" && cd / && '
              '"$2" plan ds3 --summary && '
              '"$2" capture --offline --scene ideal --plan ds4 --model latent --quiet --out "$3"')
    r = run("unshare", "-m", "--propagation", "private", "sh", "-c", script, "sh", configs,
            gonio, out, env=clean_env())
    assert r.returncode == 0, r.stderr
    assert r.stdout.splitlines()[0].startswith("plan ds3 (%s/etc/gonio/plans/ds3.yaml)" % dest)
    assert os.path.exists(os.path.join(out, "latent.model"))


def build_shared():
    """The shared data folder the build tree's binaries fall back to."""
    cache = open(os.path.join(BUILD, "CMakeCache.txt")).read()
    m = re.search(r"(?m)^GONIO_SHARED_DEFAULT:PATH=(.*)$", cache)
    return os.path.realpath(m.group(1)) if m else None


def test_installed_gonio_finds_shared_data_only_through_the_environment(dest):
    """The build's ../shared is compiled in for the build tree: the
    installed gonio must not use it (docs/install.md), only $GONIO_SHARED."""
    shared = build_shared()
    if not shared or not os.path.isdir(shared):
        pytest.skip("shared data folder not found beside the source tree")
    gonio = os.path.join(dest, "usr/bin/gonio")
    args = (gonio, "capture", "--offline", "--scene", "ideal", "--material", "nbrdf:nylon",
            "--plan", "ds4", "--quiet", "--out")
    r = run(*args, os.path.join(dest, "cap-noshared"), env=clean_env())
    assert r.returncode == 2 and "shared data folder not found (set GONIO_SHARED)" in r.stderr, \
        r.stderr
    r = run(*args, os.path.join(dest, "cap-shared"), env=dict(clean_env(), GONIO_SHARED=shared))
    assert r.returncode == 0, r.stderr


def test_readme_goniod_command(dest, tmp_path):
    """The README's goniod command, on the installed config. Without the
    gonio group (made by the package's postinst) --check says so; with a
    group that exists it passes."""
    readme = open(os.path.join(SOURCE, "README.md")).read()
    cmd = re.search(r"`(goniod --config (/etc/gonio/goniod\.yaml) \[--check\])`", readme)
    assert cmd, "README names no installed goniod command"
    config = dest + cmd.group(2)
    goniod = os.path.join(dest, "usr/bin/goniod")
    r = run(goniod, "--config", config, "--check", env=clean_env())
    try:
        grp.getgrnam("gonio")
        assert r.returncode == 0, r.stderr
    except KeyError:
        assert r.returncode == 2
        assert "group 'gonio' does not exist" in r.stderr
    text = open(config).read()
    mine = grp.getgrgid(os.getgid()).gr_name
    copy = tmp_path / "goniod.yaml"
    copy.write_text(text.replace("group: gonio", "group: " + mine))
    r = run(goniod, "--config", str(copy), "--check", env=clean_env())
    assert r.returncode == 0, r.stderr
    assert "capture_root: /var/lib/gonio/captures" in r.stdout
    assert "path: /run/goniod/goniod.sock" in r.stdout


def test_package(tmp_path):
    """make package's .deb: the files of a Debian daemon, and a postinst
    that creates the gonio user and group (run into an empty DPKG_ROOT)."""
    for tool in ("cpack", "dpkg-deb", "systemd-sysusers"):
        if not shutil.which(tool):
            pytest.skip(tool + " not installed")
    r = run("cpack", "-G", "DEB", "--config", os.path.join(BUILD, "CPackConfig.cmake"),
            "-B", str(tmp_path), cwd=BUILD)
    assert r.returncode == 0, r.stdout + r.stderr
    debs = list(tmp_path.glob("gonio_*.deb"))
    assert len(debs) == 1, os.listdir(tmp_path)
    listing = run("dpkg-deb", "-c", str(debs[0])).stdout
    for path in ("./usr/lib/systemd/system/goniod.service", "./usr/lib/sysusers.d/gonio.conf",
                 "./usr/lib/tmpfiles.d/gonio.conf", "./usr/bin/goniod", "./usr/bin/gonio",
                 "./etc/gonio/goniod.yaml", "./usr/share/gonio/models/latent-decoder.gld",
                 "./usr/share/man/man8/goniod.8") + tuple("./" + f for f in PYTHON_FILES):
        assert re.search(r" %s( |$)" % re.escape(path), listing, re.M), path
    root = tmp_path / "root"
    assert run("dpkg-deb", "-x", str(debs[0]), str(root)).returncode == 0
    control = tmp_path / "control"
    assert run("dpkg-deb", "-e", str(debs[0]), str(control)).returncode == 0
    for script in ("postinst", "prerm", "postrm"):
        assert (control / script).read_text() == open(os.path.join(BUILD, "deb", script)).read()
    conffiles = (control / "conffiles").read_text().split()
    assert "/etc/gonio/goniod.yaml" in conffiles and "/etc/gonio/plans/ds1.yaml" in conffiles
    (root / "etc" / "passwd").write_text("")
    (root / "etc" / "group").write_text("")
    env = dict(os.environ, DPKG_ROOT=str(root))
    r = run("sh", str(control / "postinst"), "configure", env=env)
    assert r.returncode == 0, r.stderr
    assert re.search(r"(?m)^gonio:x:\d+:", (root / "etc" / "group").read_text())
    assert re.search(r"(?m)^gonio:x:\d+:\d+:.*:/var/lib/gonio:",
                     (root / "etc" / "passwd").read_text())


MAINTAINER_SCRIPT = """
set -e
mount -t tmpfs tmpfs /run
mkdir -p /run/systemd/system
for step in "$@"; do
    echo "== $step" >> "$LOG"
    set -- $step
    script=$1
    shift
    sh "$DEB/$script" "$@"
done
"""


def test_maintainer_scripts(tmp_path):
    """What the maintainer scripts ask of systemd on an install, an upgrade
    and a removal (purge too), where systemd runs: a private mount
    namespace with /run/systemd/system, systemctl a recorder on PATH. Only
    systemd-sysusers and systemd-tmpfiles stay the machine's own (they are
    recorded too: the install must not touch this machine's users)."""
    if os.geteuid() != 0 or not shutil.which("unshare"):
        pytest.skip("needs root and unshare for a private /run")
    probe = run("unshare", "-m", "--propagation", "private", "true")
    if probe.returncode != 0:
        pytest.skip("no mount namespace here: " + probe.stderr.strip()[:100])
    bindir = tmp_path / "bin"
    bindir.mkdir()
    log = tmp_path / "log"
    for tool in ("systemctl", "systemd-sysusers", "systemd-tmpfiles"):
        (bindir / tool).write_text('#!/bin/sh\necho "%s $*" >> "$LOG"\n' % tool)
        (bindir / tool).chmod(0o755)
    env = {k: v for k, v in os.environ.items() if k != "DPKG_ROOT"}
    env.update(PATH="%s:%s" % (bindir, os.environ["PATH"]), LOG=str(log),
               DEB=os.path.join(BUILD, "deb"))
    steps = ["postinst configure", "prerm upgrade 0.2.0", "postinst configure 0.1.0",
             "prerm remove", "postrm remove", "postrm purge"]
    r = run("unshare", "-m", "--propagation", "private", "sh", "-c", MAINTAINER_SCRIPT, "sh",
            *steps, env=env)
    assert r.returncode == 0, r.stderr
    calls = {}
    for block in log.read_text().split("== ")[1:]:
        step, *lines = block.strip().split("\n")
        calls[step] = lines
    assert calls["postinst configure"] == ["systemd-sysusers gonio.conf",
                                           "systemd-tmpfiles --create gonio.conf",
                                           "systemctl daemon-reload"]
    assert calls["prerm upgrade 0.2.0"] == []
    assert calls["postinst configure 0.1.0"][-2:] == ["systemctl daemon-reload",
                                                      "systemctl try-restart goniod.service"]
    assert calls["prerm remove"] == ["systemctl stop goniod.service"]
    assert calls["postrm remove"] == ["systemctl daemon-reload"]
    assert calls["postrm purge"] == ["systemctl daemon-reload"]
