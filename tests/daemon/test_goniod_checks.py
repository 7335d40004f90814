#!/usr/bin/python3
"""The premise checks through goniod (docs/checks.md): a capture request's
check "isotropy" on the rotating rig profile gives its verdict in the stop
document, in the event-model fit stream and in gonio capture --wait's
output; request.json keeps it, so an aborted capture resumed is checked
too; a rig without a rotation axis and an unknown check are refused before
anything is created. The check "out-of-plane" (alone on the default rig,
or with "isotropy") reaches the same places: "insufficient" for an
anisotropic material, "sufficient" for an isotropic one. A plan sent
with the request that turns the sample (sample_azimuths) fits the
anisotropic model (aniso-ggx). With --model auto the choice and why reach
the stop document, --wait's output and the event stream too.

Run from ctest (the environment names the binaries), or by hand:
  GONIO_BIN=build/bin GONIO_TESTS_BIN=build/tests GONIO_CONFIG=configs \\
      python3 tests/daemon/test_goniod_checks.py -v
"""
import json
import os
import sys
import time
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from goniod_harness import DaemonTest, load_json
from test_goniod_events import load_validators, read_run

ANISO = "analytic:aniso-ggx?ax=0.05&ay=0.2"
ISO = "analytic:plastic-ggx"


def same(a, b):
    """a and b equal, their numbers to 1e-9 (results.json writes fewer digits)."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b))
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return abs(a - b) <= 1e-9 * max(abs(a), abs(b))
    return a == b


class ChecksTests(DaemonTest):
    pace_s = 0.0

    def assertSame(self, a, b):
        self.assertTrue(same(a, b), "%r != %r" % (a, b))

    def stop_checks(self, stop):
        self.assertEqual(stop["exit_status"], "success", stop)
        return stop["checks"]["isotropy"]

    def fit_event(self, ev, validators):
        """The run's fit descriptor and its event, every document of the run
        valid against the event model's schemas."""
        pairs = read_run(ev)
        for name, doc in pairs:
            errors = [e.message for e in validators[name].iter_errors(doc)]
            self.assertEqual(errors, [], "%s invalid: %s" % (name, json.dumps(doc)[:600]))
        fit = [d for n, d in pairs if n == "descriptor" and d["name"] == "fit"]
        self.assertEqual(len(fit), 1)
        event = [d for n, d in pairs if n == "event" and d["descriptor"] == fit[0]["uid"]]
        return fit[0], event[0]

    def test_isotropic_in_stop_document(self):
        c = self.d.connect()
        self.assertEqual(c.request("watch")["class"], "OK")
        # ideal: goniod names no calibration here, and lab's detector gives
        # counts (tests/cli/test_checks.py holds the verdict on lab, calibrated)
        r = c.request("capture", plan="ds2", name="iso", scene="ideal", rig="rotating",
                      material=ISO, check="isotropy")
        self.assertEqual(r["class"], "OK", r)
        docs = c.until_stop("iso")
        self.assertEqual(docs[0]["check"], "isotropy")
        iso = self.stop_checks(docs[-1])
        self.assertEqual(iso["verdict"], "isotropic", iso["why"])
        self.assertLess(iso["significance"], iso["threshold"])
        self.assertGreater(iso["rig_time_s"], 0)
        self.assertLess(iso["rig_time_s"], 0.2 * docs[-1]["rig_time_s"])
        # The stop document's verdict is results.json's, and request.json keeps the check.
        capdir = os.path.join(self.d.root, "iso")
        self.assertSame(load_json(os.path.join(capdir, "results.json"))["checks"]["isotropy"], iso)
        self.assertEqual(load_json(os.path.join(capdir, "request.json"))["check"], "isotropy")

    def test_out_of_plane_in_stop_document(self):
        c = self.d.connect()
        self.assertEqual(c.request("watch")["class"], "OK")
        r = c.request("capture", plan="ds2", name="oop", scene="ideal", material=ISO,
                      check="out-of-plane")
        self.assertEqual(r["class"], "OK", r)
        docs = c.until_stop("oop")
        self.assertEqual(docs[0]["check"], "out-of-plane")
        self.assertEqual(docs[-1]["exit_status"], "success", docs[-1])
        oop = docs[-1]["checks"]["out_of_plane"]
        self.assertNotIn("isotropy", docs[-1]["checks"])
        self.assertEqual(oop["verdict"], "sufficient", oop["why"])
        self.assertLess(oop["ratio"], oop["threshold"])
        self.assertEqual(oop["measurements"], 12)
        self.assertGreater(oop["rig_time_s"], 0)
        # DS2 is small: the 12 readings and the full-domain estimate's twelve, under half
        self.assertLess(oop["rig_time_s"], 0.5 * docs[-1]["rig_time_s"])
        self.assertEqual(oop["domain_pairs"], 12)
        self.assertGreater(oop["error_full"], 0)
        self.assertLessEqual(oop["error_full_interval"][0], oop["error_full"])
        capdir = os.path.join(self.d.root, "oop")
        self.assertSame(load_json(os.path.join(capdir, "results.json"))["checks"]["out_of_plane"],
                        oop)
        self.assertEqual(load_json(os.path.join(capdir, "request.json"))["check"],
                         "out-of-plane")

    def test_anisotropic_with_wait_and_event_model(self):
        validators, why = load_validators()
        ev = self.d.connect()
        if validators:
            self.assertEqual(ev.request("watch", format="event-model")["class"], "OK")
        r = self.d.gonio("capture", "--plan", "ds2", "--name", "aniso", "--rig", "rotating",
                         "--material", ANISO, "--check", "isotropy,out-of-plane", "--wait",
                         "--quiet")
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("isotropy check: anisotropic", r.stdout)
        self.assertIn("out-of-plane check: in-plane insufficient", r.stdout)
        res = load_json(os.path.join(self.d.root, "aniso", "results.json"))
        iso = res["checks"]["isotropy"]
        self.assertEqual(iso["verdict"], "anisotropic")
        self.assertGreater(iso["significance"], iso["threshold"])
        self.assertIn("against %.1f" % iso["threshold"], r.stdout)
        oop = res["checks"]["out_of_plane"]
        self.assertEqual(oop["verdict"], "insufficient", oop["why"])
        self.assertGreater(oop["ratio"], oop["threshold"])
        if not validators:
            sys.stderr.write(why + "\n")
            return
        fit, event = self.fit_event(ev, validators)
        self.assertEqual(event["data"]["isotropy_verdict"], "anisotropic")
        self.assertAlmostEqual(event["data"]["isotropy_significance"], iso["significance"],
                               delta=1e-9 * iso["significance"])
        self.assertAlmostEqual(event["data"]["isotropy_rig_time_s"], iso["rig_time_s"],
                               delta=1e-9 * iso["rig_time_s"])
        self.assertEqual(fit["data_keys"]["isotropy_rig_time_s"]["units"], "s")
        self.assertEqual(event["data"]["oop_verdict"], "insufficient")
        self.assertAlmostEqual(event["data"]["oop_ratio"], oop["ratio"],
                               delta=1e-9 * oop["ratio"])
        self.assertEqual(fit["data_keys"]["oop_rig_time_s"]["units"], "s")
        # the full-domain error estimate with its interval, as results.json has it
        self.assertIn("full-domain log error estimated %.4f (95%%: %.4f-%.4f"
                      % (oop["error_full"], *oop["error_full_interval"]), r.stdout)
        self.assertAlmostEqual(event["data"]["oop_error_full"], oop["error_full"],
                               delta=1e-9 * oop["error_full"])
        self.assertTrue(same(event["data"]["oop_error_full_interval"],
                             oop["error_full_interval"]))
        self.assertEqual(fit["data_keys"]["oop_error_full_interval"]["shape"], [2])
        self.assertEqual(event["data"]["oop_domain_pairs_used"], oop["domain_pairs_used"])
        self.assertEqual(event["data"]["isotropy_why"], iso["why"])
        self.assertNotIn("auto_chosen", event["data"])  # not --model auto

    def test_auto_choice_in_stop_document_wait_and_events(self):
        """--model auto's choice and why reach the stop document, --wait's
        output and the event-model fit stream as results.json has them."""
        validators, why = load_validators()
        c, ev = self.d.connect(), self.d.connect()
        self.assertEqual(c.request("watch")["class"], "OK")
        if validators:
            self.assertEqual(ev.request("watch", format="event-model")["class"], "OK")
        r = self.d.gonio("capture", "--plan", "ds2", "--name", "auto", "--rig", "rotating",
                         "--material", ANISO, "--model", "auto", "--check", "isotropy",
                         "--wait", "--quiet")
        self.assertEqual(r.returncode, 0, r.stderr)
        a = load_json(os.path.join(self.d.root, "auto", "results.json"))["auto"]
        # one sample azimuth: the anisotropic verdict leaves the isotropic candidates
        self.assertEqual(a["isotropy"], "anisotropic")
        self.assertIn("sample_azimuths", a["why"])
        self.assertIn("  auto: %s; %s\n" % (a["chosen"], a["why"]), r.stdout)
        stop = c.until_stop("auto")[-1]
        self.assertEqual(stop["auto"], a)
        if not validators:
            sys.stderr.write(why + "\n")
            return
        fit, event = self.fit_event(ev, validators)
        data = event["data"]
        self.assertEqual((data["auto_chosen"], data["auto_why"], data["auto_isotropy"]),
                         (a["chosen"], a["why"], a["isotropy"]))
        self.assertEqual(fit["data_keys"]["auto_why"]["dtype"], "string")
        self.assertEqual(data["isotropy_verdict"], "anisotropic")


    def test_refusals(self):
        c = self.d.connect()
        r = c.request("capture", plan="ds2", name="plain", material=ANISO, check="isotropy")
        self.assertEqual(r["code"], "bad-value", r)
        self.assertIn("rig 'default'", r["message"])
        self.assertIn("rotation", r["message"])
        r = c.request("capture", plan="ds2", name="plain", rig="rotating", check="planarity")
        self.assertEqual(r["code"], "bad-value", r)
        self.assertIn("'planarity'", r["message"])
        r = c.request("capture", plan="ds2", name="plain", rig="rotating", check=1)
        self.assertEqual(r["code"], "bad-type", r)
        g = self.d.gonio("capture", "--plan", "ds2", "--name", "plain", "--check", "isotropy")
        self.assertEqual(g.returncode, 2, g.stderr)
        self.assertIn("rig 'default'", g.stderr)
        # A material's parameters are key=value pairs of a few characters; a path is none.
        for bad in ("analytic:aniso-ggx?ax=../../etc", "analytic:aniso-ggx?", "analytic:../x?a=1"):
            r = c.request("capture", plan="ds2", name="plain", rig="rotating", material=bad)
            self.assertEqual(r["code"], "bad-value", r)
            self.assertIn("not a valid name", r["message"])
        self.assertFalse(os.path.exists(os.path.join(self.d.root, "plain")))
        # A capture without the check has none.
        c.request("watch")
        r = c.request("capture", plan="ds2", name="none", rig="rotating", material=ANISO)
        self.assertEqual(r["class"], "OK", r)
        stop = c.until_stop("none")[-1]
        self.assertEqual(stop["checks"], {})

    def test_sample_azimuths_fit_the_anisotropic_model(self):
        """A plan sent with the request turns the sample to three azimuths
        (sample_azimuths: 3, 45 deg apart); the journal records each pair on
        the turned sample and aniso-ggx fitted to them is the material."""
        c = self.d.connect()
        c.request("watch")
        plan = ("grid: {theta_i_step: 30, diffuse_step: 20, glossy_step: 3}\n"
                "sample_azimuths: 3\n")
        r = c.request("capture", plan="ds3-az3.yaml", plan_text=plan, name="az",
                      scene="ideal", rig="rotating", material=ANISO, model="aniso-ggx")
        self.assertEqual(r["class"], "OK", r)
        stop = c.until_stop("az")[-1]
        self.assertEqual(stop["exit_status"], "success", stop)
        with open(os.path.join(self.d.root, "az", "samples.csv")) as f:
            rows = [l.split(",") for l in f.read().splitlines()[1:]]
        self.assertEqual(len(rows), 3 * 52)
        self.assertEqual(sorted({round(float(r[3]), 6) for r in rows}), [0, 270, 315])
        res = load_json(os.path.join(self.d.root, "az", "results.json"))
        self.assertEqual(res["model"], "aniso-ggx")
        self.assertLess(res["errors"]["full"]["log"], 1e-3)


class ChecksResumeTests(DaemonTest):
    pace_s = 0.02  # slow enough to abort mid-way

    def test_resume_keeps_the_check(self):
        c = self.d.connect()
        c.request("watch")
        r = c.request("capture", plan="ds2", name="ab", rig="rotating", material=ANISO,
                      check="isotropy")
        self.assertEqual(r["class"], "OK", r)
        while c.read()["class"] != "event":
            pass
        time.sleep(0.2)
        self.assertEqual(c.request("abort")["class"], "OK")
        stop = c.until_stop("ab")[-1]
        self.assertEqual(stop["exit_status"], "abort")
        self.assertNotIn("checks", stop)
        r = c.request("resume", capture_id="ab")
        self.assertEqual(r["class"], "OK", r)
        docs = c.until_stop("ab")
        self.assertTrue(docs[0]["resume"])
        self.assertEqual(docs[0]["check"], "isotropy")
        self.assertEqual(docs[-1]["exit_status"], "success", docs[-1])
        self.assertEqual(docs[-1]["checks"]["isotropy"]["verdict"], "anisotropic")


if __name__ == "__main__":
    unittest.main()
