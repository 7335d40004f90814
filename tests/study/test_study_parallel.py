"""The scale-out recipes of docs/study.md, run rather than only written:
the one-machine GNU parallel block as written (a small study in OPTS, the
build's bin under build/bin), its merge equal to the same study unsharded
(time columns aside); the Slurm script and the ssh recipe parse (bash -n)."""
import csv
import os
import re
import shutil
import subprocess
import tempfile

import pytest

BIN = os.path.abspath(os.environ.get("GONIO_BIN", "build/bin"))
DOC = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "docs", "study.md")
SMALL = "--materials default --plans ds4,ds3 --models abc --scenes ideal,lab"
TIME_COLUMNS = {"fit_wall_s", "fit_cpu_s"}


def blocks():
    return re.findall(r"```sh\n(.*?)```", open(DOC).read(), re.S)


def block(marker):
    found = [b for b in blocks() if marker in b]
    assert len(found) == 1, "docs/study.md: one ```sh block with %r" % marker
    return found[0]


def rows(folder):
    with open(os.path.join(folder, "results.csv"), newline="") as f:
        return [{k: v for k, v in r.items() if k not in TIME_COLUMNS}
                for r in csv.DictReader(f)]


def test_parallel_recipe_merges_to_the_unsharded_study():
    if not shutil.which("parallel"):
        pytest.skip("GNU parallel not installed (make deps)")
    recipe = block("# one machine: GNU parallel")
    assert re.search(r'(?m)^OPTS="[^"]*"$', recipe)
    recipe = re.sub(r'(?m)^OPTS="[^"]*"$', 'OPTS="%s"' % SMALL, recipe)
    with tempfile.TemporaryDirectory(prefix="study_parallel_") as d:
        os.makedirs(os.path.join(d, "build"))
        os.symlink(BIN, os.path.join(d, "build", "bin"))
        env = dict(os.environ, HOME=d)  # parallel keeps its state in ~/.parallel
        r = subprocess.run(["sh", "-ec", recipe], cwd=d, env=env, capture_output=True,
                           text=True, timeout=900)
        assert r.returncode == 0, r.stdout + r.stderr
        shards = sorted(x for x in os.listdir(os.path.join(d, "study")) if x.startswith("shard-"))
        assert shards == ["shard-%d" % i for i in range(1, 5)]
        one = os.path.join(d, "one")
        r = subprocess.run([os.path.join(BIN, "gonio"), "study", *SMALL.split(), "--out", one],
                           capture_output=True, text=True, timeout=900)
        assert r.returncode == 0, r.stderr
        merged, single = rows(os.path.join(d, "study", "all")), rows(one)
        assert len(single) == 4
        assert merged == single


@pytest.mark.parametrize("marker", ["#SBATCH --array", "parallel -j1 -S"])
def test_cluster_recipes_parse(marker):
    if not shutil.which("bash"):
        pytest.skip("bash not installed")
    r = subprocess.run(["bash", "-n"], input=block(marker), capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
