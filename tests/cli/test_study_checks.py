"""The premise checks in the study and its report (docs/study.md,
docs/checks.md): `gonio study --check isotropy,out-of-plane --rig rotating`
gives every row the capture's isotropy verdict and rig time, and the row of
the model the capture fitted its out-of-plane verdict and rig time, the same
figures as the job's own results.json, in results.json and results.csv; the
report's table of all rows shows them in their columns; a study without a
check has the columns empty; a rig without the axis is refused before
anything is written, and a study folder of other checks is not resumed."""
import csv
import json
import os
import re
import subprocess
import tempfile

import pytest

BIN = os.environ.get("GONIO_BIN", "build/bin")
GONIO = os.path.join(BIN, "gonio")
ANISO = "analytic:aniso-ggx?ax=0.08&ay=0.16&phi=30"


def gonio(*args):
    return subprocess.run([GONIO, *args], capture_output=True, text=True, timeout=600)


def study(out, *extra):
    return gonio("study", "--materials", ANISO, "--plans", "ds3", "--models", "abc,abc-prior",
                 "--scenes", "ideal", "--jobs", "1", "--quiet", "--out", out, *extra)


@pytest.fixture
def tmp():
    with tempfile.TemporaryDirectory(prefix="study_checks_") as d:
        yield d


def duration(s):
    """report/html.c's html_duration."""
    if s is None:
        return "–"
    return f"{s:.1f} s" if s < 100 else f"{s / 60:.1f} min"


def report_rows(out):
    """The report's table of all rows: {row_id: {heading: cell}}."""
    with open(os.path.join(out, "report.html"), encoding="utf-8") as f:
        page = f.read()
    table = page[page.index('id="rows"'):]
    table = table[:table.index("</table>")]
    heads = re.findall(r"<th[^>]*>(.*?)</th>", table)
    rows = {}
    for tr in re.findall(r"<tr><td.*?</tr>", table):
        cells = re.findall(r"<td[^>]*>(.*?)</td>", tr)
        assert len(cells) == len(heads)
        rows[cells[0]] = dict(zip(heads, cells))
    return rows


def rows_of(out):
    with open(os.path.join(out, "results.json")) as f:
        return {r["model"]: r for r in json.load(f)["rows"]}


def test_check_columns(tmp):
    out = os.path.join(tmp, "st")
    r = study(out, "--check", "isotropy,out-of-plane", "--rig", "rotating")
    assert r.returncode == 0, r.stderr
    rows = rows_of(out)
    abc, prior = rows["abc"], rows["abc-prior"]
    # the job's capture: its own results.json holds the checks' figures
    job = os.path.dirname(os.path.join(out, abc["samples_file"]))
    with open(os.path.join(job, "results.json")) as f:
        checks = json.load(f)["checks"]
    iso, oop = checks["isotropy"], checks["out_of_plane"]
    assert iso["verdict"] == "anisotropic" and oop["verdict"] == "insufficient"
    for row in (abc, prior):
        assert row["isotropy"] == "anisotropic"
        assert row["isotropy_s"] == pytest.approx(iso["rig_time_s"])
    # the out-of-plane check judged the capture's model, the first: abc
    assert abc["oop"] == "insufficient"
    assert abc["oop_s"] == pytest.approx(oop["rig_time_s"])
    assert prior["oop"] is None and prior["oop_s"] is None
    assert abc["isotropy_s"] != abc["oop_s"]  # two figures, not one twice
    # results.csv: the same values under the same names
    with open(os.path.join(out, "results.csv")) as f:
        csv_rows = {r["model"]: r for r in csv.DictReader(f)}
    assert csv_rows["abc"]["isotropy"] == "anisotropic"
    assert float(csv_rows["abc"]["isotropy_s"]) == pytest.approx(iso["rig_time_s"], rel=1e-5)
    assert csv_rows["abc"]["oop"] == "insufficient"
    assert float(csv_rows["abc"]["oop_s"]) == pytest.approx(oop["rig_time_s"], rel=1e-5)
    assert csv_rows["abc-prior"]["oop"] == "" and csv_rows["abc-prior"]["oop_s"] == ""
    # the report: a column per check and its rig time
    page = report_rows(out)
    cells = page[abc["row_id"]]
    assert cells["isotropy"] == "anisotropic"
    assert cells["isotropy rig time"] == duration(iso["rig_time_s"])
    assert cells["out of plane"] == "insufficient"
    assert cells["out-of-plane rig time"] == duration(oop["rig_time_s"])
    cells = page[prior["row_id"]]
    assert cells["isotropy"] == "anisotropic"
    assert cells["out of plane"] == "–" and cells["out-of-plane rig time"] == "–"
    # a rerun with other checks would mix rows of two studies
    r = study(out, "--check", "isotropy", "--rig", "rotating")
    assert r.returncode == 2 and "checks or rig" in r.stderr


def test_no_check_empty_columns(tmp):
    out = os.path.join(tmp, "st")
    r = study(out)
    assert r.returncode == 0, r.stderr
    for row in rows_of(out).values():
        assert row["isotropy"] is None and row["isotropy_s"] is None
        assert row["oop"] is None and row["oop_s"] is None
        cells = report_rows(out)[row["row_id"]]
        assert cells["isotropy"] == "–" and cells["out of plane"] == "–"


def test_rig_without_the_axis_refused(tmp):
    out = os.path.join(tmp, "st")
    r = study(out, "--check", "isotropy")
    assert r.returncode == 2
    assert "rotation" in r.stderr and "'default'" in r.stderr
    assert not os.path.exists(out)
    r = study(out, "--check", "sideways", "--rig", "rotating")
    assert r.returncode == 2 and "sideways" in r.stderr
