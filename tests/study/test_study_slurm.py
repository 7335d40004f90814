"""The Slurm recipe of docs/study.md on a real Slurm: a one-node cluster
(Debian's slurmctld, slurmd and munged) configured and started in a temporary
folder, the documented study.sh and merge.sh written from their blocks as they
are, the submission block run as written with a small study in OPTS and three
shares, and the merged study compared with the same study run unsharded (time
columns aside). The daemons run as the user running the test (root or not:
slurmd then runs only that user's jobs, which are all there are); skipped
where they are missing. Every daemon is stopped at the end, also on failure;
nothing is written outside the temporary folder."""
import ctypes
import json
import os
import pwd
import re
import shutil
import socket
import subprocess
import tempfile
import time

import pytest

from test_study_parallel import BIN, SMALL, block, rows

DAEMONS = ["munged", "slurmctld", "slurmd", "sbatch", "squeue", "sinfo", "scancel"]
SHARES = 3
WAIT_S = 600  # jobs take seconds; the bound only turns a stuck cluster into a failure


def die_with_parent():
    """Run in the daemon's child: a SIGTERM when the test's process dies, so
    a test killed by ctest's timeout leaves no daemon behind (PR_SET_PDEATHSIG)."""
    ctypes.CDLL(None, use_errno=True).prctl(1, 15, 0, 0, 0)


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def slurm_conf(d, node, user):
    cpus = max(2, os.cpu_count() or 1)  # study.sh asks for 2 CPUs a task
    return "\n".join([
        "ClusterName=goniotest",
        "SlurmctldHost=%s(127.0.0.1)" % node,
        "SlurmctldPort=%d" % free_port(),
        "SlurmdPort=%d" % free_port(),
        "SlurmUser=%s" % user, "SlurmdUser=%s" % user,
        "AuthType=auth/munge", "CredType=cred/munge",
        "AuthInfo=socket=%s/munge.sock" % d,
        "StateSaveLocation=%s/state" % d, "SlurmdSpoolDir=%s/spool" % d,
        "SlurmctldPidFile=%s/slurmctld.pid" % d, "SlurmdPidFile=%s/slurmd.pid" % d,
        "SlurmctldLogFile=%s/slurmctld.log" % d, "SlurmdLogFile=%s/slurmd.log" % d,
        # no cgroups: processes tracked through /proc, no task binding
        "ProctrackType=proctrack/linuxproc", "TaskPlugin=task/none",
        "SelectType=select/cons_tres", "SelectTypeParameters=CR_CPU",
        "SlurmdParameters=config_overrides",
        "JobCompType=jobcomp/none", "AccountingStorageType=accounting_storage/none",
        "MpiDefault=none", "ReturnToService=2",
        # a failed share cancels the merge instead of leaving it pending forever
        "DependencyParameters=kill_invalid_depend",
        "NodeName=%s NodeAddr=127.0.0.1 CPUs=%d State=UNKNOWN" % (node, cpus),
        "PartitionName=test Nodes=ALL Default=YES MaxTime=INFINITE State=UP", ""])


def logs(d):
    out = []
    for root, _, files in os.walk(d):
        for f in sorted(files):
            if f.endswith((".log", ".out")):
                path = os.path.join(root, f)
                out.append("== %s\n%s" % (path, open(path, errors="replace").read()[-3000:]))
    return "\n".join(out)


def wait_for(what, check, d, timeout=60):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if check():
            return
        time.sleep(0.5)
    pytest.fail("Slurm: %s not reached in %d s\n%s" % (what, timeout, logs(d)))


def query(args, env):
    r = subprocess.run(args, env=env, capture_output=True, text=True, timeout=30)
    return r.stdout if r.returncode == 0 else None


@pytest.fixture
def cluster():
    """(folder, environment) of a running one-node Slurm; stopped afterwards."""
    missing = [x for x in DAEMONS if not shutil.which(x, path=os.environ.get("PATH", "") + ":/usr/sbin")]
    if missing:
        pytest.skip("Slurm not installed (make deps): no %s" % " ".join(missing))
    d = tempfile.mkdtemp(prefix="study_slurm_")
    os.chmod(d, 0o755)  # munged wants its socket's folder searchable by all
    for sub in ("state", "spool", "work"):
        os.mkdir(os.path.join(d, sub))
    key = os.path.join(d, "munge.key")
    with open(key, "wb") as f:
        f.write(os.urandom(1024))
    os.chmod(key, 0o400)
    node = socket.gethostname().split(".")[0]
    with open(os.path.join(d, "slurm.conf"), "w") as f:
        f.write(slurm_conf(d, node, pwd.getpwuid(os.geteuid()).pw_name))
    env = dict(os.environ, SLURM_CONF=os.path.join(d, "slurm.conf"),
               PATH=BIN + ":" + os.environ.get("PATH", "/usr/bin:/bin") + ":/usr/sbin")
    for k in [k for k in env if k.startswith(("SLURM_", "SBATCH_", "SQUEUE_")) and k != "SLURM_CONF"]:
        del env[k]
    procs = []

    def start(name, args):
        out = open(os.path.join(d, name + ".out"), "w")
        procs.append(subprocess.Popen(args, env=env, stdout=out, stderr=subprocess.STDOUT,
                                      stdin=subprocess.DEVNULL,
                                      preexec_fn=die_with_parent))
        out.close()

    try:
        start("munged", ["munged", "-F", "-f", "--key-file=" + key,
                         "--socket=%s/munge.sock" % d, "--pid-file=%s/munged.pid" % d,
                         "--log-file=%s/munged.log" % d, "--seed-file=%s/munged.seed" % d])
        wait_for("munged socket", lambda: os.path.exists(os.path.join(d, "munge.sock")), d)
        start("slurmctld", ["slurmctld", "-D", "-i"])
        start("slurmd", ["slurmd", "-D", "-N", node])
        wait_for("node idle", lambda: (query(["sinfo", "-h", "-N", "-o", "%T"], env) or "")
                 .strip() == "idle", d)
        yield d, env
    finally:
        if procs[1:]:
            subprocess.run(["scancel", "--full", "--user", str(os.geteuid())], env=env,
                           capture_output=True, timeout=30)
        for p in reversed(procs):
            p.terminate()
        for p in reversed(procs):
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
        shutil.rmtree(d, ignore_errors=True)


def test_slurm_array_merges_to_the_unsharded_study(cluster):
    d, env = cluster
    work = os.path.join(d, "work")
    with open(os.path.join(work, "study.sh"), "w") as f:
        f.write(block("#SBATCH --array"))
    with open(os.path.join(work, "merge.sh"), "w") as f:
        f.write(block("#SBATCH --job-name=gonio-study-merge"))
    submit = block("# submit:")
    for name, value in (("OPTS", '"%s"' % SMALL), ("N", str(SHARES))):
        pattern = r"(?m)^%s=.*$" % name
        assert re.search(pattern, submit), "docs/study.md: the submission sets %s" % name
        submit = re.sub(pattern, "%s=%s" % (name, value), submit)
    r = subprocess.run(["sh", "-ec", submit], cwd=work, env=env, capture_output=True,
                       text=True, timeout=60)
    assert r.returncode == 0, r.stdout + r.stderr + logs(d)
    wait_for("all jobs done", lambda: query(["squeue", "-h"], env) == "", d, WAIT_S)
    merged = os.path.join(work, "study", "all")
    assert os.path.isfile(os.path.join(merged, "results.csv")), "no merge\n" + logs(d)
    with open(os.path.join(merged, "results.json")) as f:
        summary = json.load(f)
    assert summary["complete"] and summary["missing"] == [], "merge incomplete: %s\n%s" % (
        summary["missing"], logs(d))
    shards = sorted(x for x in os.listdir(os.path.join(work, "study")) if x.startswith("shard-"))
    assert shards == ["shard-%d" % i for i in range(1, SHARES + 1)], logs(d)
    one = os.path.join(d, "one")
    r = subprocess.run([os.path.join(BIN, "gonio"), "study", *SMALL.split(), "--out", one],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    single = rows(one)
    assert len(single) == 4
    assert rows(merged) == single, "the merged array differs from the unsharded study\n" + logs(d)
