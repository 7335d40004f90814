"""gonio report and gonio plot end to end (standard library only).

The report must be one self-contained page: every figure inline, every
image a data URI, nothing fetched. Its SVG (inline and the plot files)
must parse as XML, its tables must carry the study's numbers, and bad
input must fail cleanly."""
import glob
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import unittest
import xml.etree.ElementTree as ET

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import fixture  # noqa: E402

BIN = os.environ.get("GONIO_BIN", "build/bin")
GONIO = os.path.join(BIN, "gonio")
SVG_NS = "{http://www.w3.org/2000/svg}"


def gonio(*args):
    return subprocess.run([GONIO] + list(args), capture_output=True, text=True, timeout=120)


class Study:
    """One fixture study and its report, shared by the tests of a run."""
    dir = None
    rows = None
    html = None

    @classmethod
    def get(cls):
        if cls.dir is None:
            base = os.environ.get("GONIO_TMP") or tempfile.gettempdir()
            os.makedirs(base, exist_ok=True)
            cls.dir = tempfile.mkdtemp(prefix="report-", dir=base)
            cls.rows = fixture.make_study(BIN, cls.dir)
            r = gonio("report", cls.dir, "--quiet")
            if r.returncode != 0:
                raise AssertionError("gonio report failed: " + r.stderr)
            with open(os.path.join(cls.dir, "report.html"), encoding="utf-8") as f:
                cls.html = f.read()
        return cls


def inline_svgs(html):
    return re.findall(r"<svg\b.*?</svg>", html, flags=re.S)


class ReportTests(unittest.TestCase):
    def setUp(self):
        self.s = Study.get()

    def test_self_contained(self):
        html = self.s.html
        self.assertNotIn("http:", html)
        self.assertNotIn("https:", html)
        self.assertNotIn("<script", html)
        self.assertNotIn("<link", html)
        self.assertNotIn("url(", re.sub(r"url\(#[\w-]+\)", "", html))  # only local clip ids
        srcs = re.findall(r'src="([^"]*)"', html)
        self.assertGreater(len(srcs), 0, "the fixture's rendering must be embedded")
        for s in srcs:
            self.assertTrue(s.startswith("data:image/png;base64,"), s[:60])
        for h in re.findall(r'href="([^"]*)"', html):
            self.assertTrue(h.startswith("#"), h)

    def test_inline_svgs_parse(self):
        svgs = inline_svgs(self.s.html)
        # 2 scenes x 2 domains x (pareto + bars) + slices of ds2 and ds4 of
        # the material whose ground truth opens ('other' has no files at
        # all: its slices are left out with a note)
        self.assertGreaterEqual(len(svgs), 8)
        ids = set()
        for svg in svgs:
            root = ET.fromstring(svg)
            self.assertEqual(root.tag, "svg")
            for el in root.iter():
                if "id" in el.attrib:
                    self.assertNotIn(el.attrib["id"], ids, "ids must be unique in the page")
                    ids.add(el.attrib["id"])
            texts = [t.text for t in root.iter("text") if t.text]
            self.assertTrue(any(t.startswith("10") or t.startswith("0.") for t in texts))

    def test_plot_files_parse_and_have_pngs(self):
        files = sorted(glob.glob(os.path.join(self.s.dir, "plots", "*.svg")))
        self.assertEqual(len(files), len(inline_svgs(self.s.html)))
        for path in files:
            root = ET.parse(path).getroot()
            self.assertEqual(root.tag, SVG_NS + "svg")
            w, h = float(root.get("width")), float(root.get("height"))
            self.assertGreater(w, 100)
            with open(path[:-4] + ".png", "rb") as f:
                head = f.read(24)
            self.assertEqual(head[:8], b"\x89PNG\r\n\x1a\n")
            # PNG width from IHDR: the figure at scale 1.5
            self.assertEqual(int.from_bytes(head[16:20], "big"), int(-(-w * 1.5 // 1)))

    def test_tables_carry_the_numbers(self):
        html = self.s.html
        # DS1 -> DS4: full-domain log error of abc on ds4, ideal
        v = fixture.error("default", "ideal", "ds4", "abc", "full", "log")
        self.assertIn("<td>%.3g</td>" % v, html)
        # in-plane vs out-of-plane: the ratio of full log errors, computed here
        a = fixture.error("other", "lab", "inplane-full", "latent", "full", "log")
        b = fixture.error("other", "lab", "oop200k", "latent", "full", "log")
        self.assertIn("<td>%.3g</td>" % (a / b), html)
        # the best of a DS row is bold: ds1 for abc
        best = fixture.error("default", "ideal", "ds1", "abc", "inplane", "log")
        self.assertIn('<td class="best">%.3g</td>' % best, html)
        # every row is in the full table
        for row in self.s.rows:
            self.assertIn(">%s</td>" % row["row_id"], html)

    def test_pareto_front_points_are_the_front(self):
        # In the pareto figure of the full domain, scene ideal, the filled
        # markers are the front: default's errors fall with rig time except
        # ds2 (0.025 at 196 s) vs ds1 (0.02 at 950 s): all of ds4, ds3,
        # ds2, ds1, inplane-full, oop200k of the best model (abc, as mlp
        # has no full error) are on it.
        svg = [s for s in inline_svgs(self.s.html) if 'id="pareto-full-ideal-clip0"' in s][0]
        root = ET.fromstring(svg)
        on = [p.find("title").text for p in root.iter("path")
              if p.find("title") is not None and "on the Pareto front" in p.find("title").text]
        on_default = sorted(t.split(":")[0] for t in on if t.startswith("default."))
        self.assertEqual(on_default, sorted("default.ideal.%s.abc" % p for p in fixture.PLANS))

    def test_slices_and_renders(self):
        html = self.s.html
        self.assertIn('id="slices-default-ideal-ds4"', html)
        self.assertIn('id="slices-default-ideal-ds2"', html)
        self.assertIn("truth | ds4/abc | ds4/latent", html)  # grid labels, manifest order
        # 'other' cannot be opened: a note, not a failure
        self.assertIn("builtin:does-not-exist", html)


CHECK_JS = """<script>
window.addEventListener('load', function () {
  var im = Array.from(document.images);
  var ok = im.filter(function (i) { return i.complete && i.naturalWidth > 0; }).length;
  var sv = Array.from(document.querySelectorAll('svg'));
  var drawn = sv.filter(function (s) { var b = s.getBBox(); return b.width > 0 && b.height > 0; });
  var e = document.createElement('pre');
  e.id = 'gonio-check';
  e.textContent = 'images ' + ok + '/' + im.length + ' svgs ' + drawn.length + '/' + sv.length +
      ' resources ' + performance.getEntriesByType('resource').length;
  document.body.appendChild(e);
});
</script>"""


def chromium():
    return os.environ.get("GONIO_CHROMIUM") or shutil.which("chromium") or \
        shutil.which("chromium-browser")


class ChromiumTests(unittest.TestCase):
    """The report in a real browser with no network: every image decodes,
    every inline SVG lays out, nothing is fetched. A copy of the page gets a
    check script (the report itself has none); Chromium runs headless in a
    network namespace of its own (unshare -n) where the system allows it,
    and with every host name unresolvable and a dead proxy either way."""

    def test_opens_offline(self):
        s = Study.get()
        page = os.path.join(s.dir, "check.html")
        with open(page, "w", encoding="utf-8") as f:
            f.write(s.html.replace("</body>", CHECK_JS + "</body>"))
        n_img = len(re.findall(r"<img\b", s.html))
        n_svg = len(inline_svgs(s.html))
        cmd = [chromium(), "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
               "--disable-extensions", "--disable-background-networking", "--disable-sync",
               "--disable-dev-shm-usage", "--proxy-server=127.0.0.1:9",
               "--host-resolver-rules=MAP * ~NOTFOUND",
               "--user-data-dir=" + os.path.join(s.dir, "chromium-profile"),
               "--virtual-time-budget=5000", "--dump-dom", "file://" + os.path.abspath(page)]
        unshare = shutil.which("unshare")
        if unshare and subprocess.run([unshare, "-n", "true"],
                                      capture_output=True).returncode == 0:
            cmd = [unshare, "-n"] + cmd
        r = subprocess.run(cmd, capture_output=True, text=True, timeout=180)
        m = re.search(r'<pre id="gonio-check">([^<]*)</pre>', r.stdout)
        self.assertIsNotNone(m, "no check marker in the DOM; chromium said: " + r.stderr[-2000:])
        self.assertEqual(m.group(1), "images %d/%d svgs %d/%d resources 0" %
                         (n_img, n_img, n_svg, n_svg))
        self.assertGreater(n_img, 0)
        self.assertGreater(n_svg, 0)


class BadInputTests(unittest.TestCase):
    def setUp(self):
        base = os.environ.get("GONIO_TMP") or tempfile.gettempdir()
        os.makedirs(base, exist_ok=True)
        self.dir = tempfile.mkdtemp(prefix="report-bad-", dir=base)

    def tearDown(self):
        shutil.rmtree(self.dir, ignore_errors=True)

    def test_missing_results(self):
        r = gonio("report", self.dir)
        self.assertEqual(r.returncode, 2)
        self.assertIn("results.json", r.stderr)
        self.assertEqual(os.listdir(self.dir), [])

    def test_bad_field(self):
        with open(os.path.join(self.dir, "results.json"), "w") as f:
            json.dump({"format": "gonio-study-1", "rows": [
                {"material": "m", "scene": "s", "plan": "p", "model": "abc",
                 "rig_time_s": "slow"}]}, f)
        r = gonio("report", self.dir)
        self.assertEqual(r.returncode, 2)
        self.assertIn("rig_time_s", r.stderr)
        self.assertIn("row 0", r.stderr)
        self.assertFalse(os.path.exists(os.path.join(self.dir, "report.html")))

    def test_truncated_json(self):
        with open(os.path.join(self.dir, "results.json"), "w") as f:
            f.write('{"format": "gonio-study-1", "rows": [')
        r = gonio("report", self.dir)
        self.assertEqual(r.returncode, 2)
        self.assertIn("results.json", r.stderr)

    def test_manifest_cannot_pull_other_files(self):
        with open(os.path.join(self.dir, "results.json"), "w") as f:
            json.dump({"format": "gonio-study-1", "rows": [
                {"material": "m", "scene": "s", "plan": "p", "model": "abc",
                 "rig_time_s": 10, "full_log": 0.1, "inplane_log": 0.1}]}, f)
        os.makedirs(os.path.join(self.dir, "renders", "x"))
        with open(os.path.join(self.dir, "renders", "x", "render.json"), "w") as f:
            json.dump({"images": [{"label": "t", "png": "../../results.json"}]}, f)
        r = gonio("report", self.dir, "--no-plots")
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("not a file name", r.stderr)
        with open(os.path.join(self.dir, "report.html")) as f:
            self.assertNotIn("data:image", f.read())
        self.assertFalse(os.path.exists(os.path.join(self.dir, "plots")))

    def test_plot_usage_errors(self):
        self.assertEqual(gonio("plot", "slices", "--material", "default", "-o", "x.pdf")
                         .returncode, 2)
        r = gonio("plot", "slices", "--material", "nope:x", "-o",
                  os.path.join(self.dir, "x.svg"))
        self.assertEqual(r.returncode, 2)
        self.assertIn("nope:x", r.stderr)
        self.assertEqual(gonio("plot", "slices", "--material", "default", "--theta-i",
                               "10,abc", "-o", os.path.join(self.dir, "x.svg")).returncode, 2)
        self.assertEqual(os.listdir(self.dir), [])


if __name__ == "__main__":
    if "ChromiumTests" in sys.argv and not chromium():
        print("SKIPPED: chromium not found (set GONIO_CHROMIUM or install chromium): the "
              "report was not opened in a browser")
        sys.exit(77)
    unittest.main()
