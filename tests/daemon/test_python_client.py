#!/usr/bin/python3
"""The Python client (python/gonio, docs/python.md) against a real goniod:
on the in-process simulated rig (ClientTests) and on Modbus TCP to a
gonio-sim process (ClientModbusTests). It runs captures, follows them as
event-model pairs, pauses, resumes and aborts, reads the capture directory
and evaluates the fitted model through libgonio_model.so; the example of
docs/python.md runs as written.

Run from ctest (the environment names the binaries), or by hand:
  GONIO_BIN=build/bin GONIO_TESTS_BIN=build/tests GONIO_CONFIG=configs \\
      python3 tests/daemon/test_python_client.py -v
"""
import math
import os
import re
import sys
import time
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from goniod_harness import BIN, SOURCE, START_S, Daemon, DaemonTest, read_samples
import test_goniod_events
from test_goniod_modbus import ModbusRig

sys.path.insert(0, os.path.join(SOURCE, "python"))
os.environ.setdefault("GONIO_MODEL_LIB",
                      os.path.join(BIN, "..", "python", "libgonio_model.so"))
import gonio


def plan_log_error(cap, fitted):
    """results.json's plan-domain log error (brdf/metrics.h) of fitted
    against the samples."""
    terms = []
    for ti, pr, fr in zip(cap.samples["theta_i"], fitted, cap.samples["rgb"]):
        c = math.cos(math.radians(ti))
        terms += [abs(math.log1p(p * c) - math.log1p(f * c)) for p, f in zip(pr, fr)]
    return sum(terms) / len(terms)


class Checks:
    def setUp(self):
        self.validators, why = test_goniod_events.load_validators()
        if self.validators is None:
            self.skipTest(why)
        super().setUp()

    check_run = test_goniod_events.EventModelTests.check_run

    def follow(self, client, plan, **fields):
        """A capture through the client, followed to its stop: (reply,
        pairs, Capture)."""
        events = client.watch()
        reply = client.capture(plan, **fields)
        pairs = list(events)
        return reply, pairs, gonio.read_capture(reply["dir"])

    def check_capture(self, pairs, cap):
        """Valid documents whose events are the journal's samples, and the
        model file evaluated at the samples' angles giving results.json's
        plan error."""
        start, streams, stop = self.check_run(pairs)
        self.assertEqual(stop["exit_status"], "success", stop)
        events = streams["primary"][1]
        self.assertEqual(len(cap), len(events))
        by_point = read_samples(os.path.join(cap.dir, "samples.csv"))
        self.assertEqual([e["data"]["rgb"] for e in events],
                         [list(map(float, by_point[p])) for p in cap.samples["point"]])
        self.assertEqual([list(r) for r in cap.samples["rgb"]],
                         [e["data"]["rgb"] for e in events])
        model = gonio.Model(cap.model_file)
        fitted = model.eval_inplane(cap.samples["theta_i"], cap.samples["theta_r"])
        self.assertAlmostEqual(plan_log_error(cap, fitted), cap.results["errors"]["plan"]["log"],
                               places=9)
        spherical = model.eval(cap.samples["theta_i"], cap.samples["phi_i"],
                               cap.samples["theta_o"], cap.samples["phi_o"])
        for a, b in zip(fitted, spherical):
            for x, y in zip(a, b):
                self.assertAlmostEqual(x, y, places=9)
        return start, streams, stop


class ClientTests(Checks, DaemonTest):
    pace_s = 0.02

    def client(self):
        return gonio.Client(self.d.sock, timeout=2 * START_S)

    def test_capture_follow_read_evaluate(self):
        """Every capture field sent (two captures between them), the run
        followed, the directory read, the model evaluated."""
        with self.client() as client:
            self.assertEqual(client.status()["state"], "idle")
            self.assertEqual(client.version["proto_major"], 1)
            reply, pairs, cap = self.follow(
                client, "ds3", name="py", scene="ideal", material="builtin:nylon", rig="default",
                model="abc", order="travel", stop="all", truth="builtin:nylon", prescan=2)
            self.assertEqual(reply["capture_id"], "py")
            start, _, _ = self.check_capture(pairs, cap)
            self.assertEqual((start["order"], start["prescan"], start["sample"]["truth"]),
                             ("travel", 2, "builtin:nylon"))
            self.assertEqual(cap.request["truth"], "builtin:nylon")
            reply, pairs, cap = self.follow(client, "ds2", name="pa", order="adaptive",
                                            budget=0.5, stop_target=0.001)
            start, _, stop = self.check_capture(pairs, cap)
            self.assertEqual((start["budget"], start["stop_target"]), (0.5, 0.001))
            self.assertEqual(stop["stop_reason"], "budget")

    def test_plan_sent_with_the_request(self):
        """plan_text: a plan goniod cannot read travels as text, and the
        capture measures its pairs."""
        text = ("pairs:\n  - [20, -30]\n  - [20, 30]\n  - [45, 10]\n  - [45, 60]\n"
                "order: as-written\nstop: all\n")
        with self.client() as client:
            reply, pairs, cap = self.follow(client, "/nowhere/mine.yaml", plan_text=text,
                                            name="ps")
            self.check_capture(pairs, cap)
            self.assertEqual([[p["theta_i"], p["theta_r"]] for p in cap.plan["pairs"]],
                             [[20, -30], [20, 30], [45, 10], [45, 60]])
            kept = os.path.join(os.path.realpath(cap.dir), "request", "plan", "mine.yaml")
            self.assertEqual(cap.request["plan"], kept)
            with self.assertRaises(gonio.GonioError) as e:
                client.capture("ds4", plan_text=5)
            self.assertEqual(e.exception.code, "bad-type")

    def test_pause_resume_abort(self):
        with self.client() as client:
            events = client.watch()
            client.capture("ds3", name="pr")
            pairs = [next(events)]
            name, doc = pairs[0]
            self.assertEqual(name, "start")
            while pairs[-1][0] != "event":
                pairs.append(next(events))
            client.pause()
            self.assertEqual(client.status()["state"], "paused")
            client.resume()
            pairs.append(next(events))  # it goes on
            self.assertEqual(pairs[-1][0], "event")
            client.pause()
            client.abort()
            _, _, stop = self.check_run(pairs + list(events))
            self.assertEqual(stop["exit_status"], "abort")
            with self.assertRaises(gonio.GonioError) as e:
                client.pause()
            self.assertEqual(e.exception.code, "not-running")
            events = client.watch()
            self.assertEqual(client.resume("pr")["capture_id"], "pr")
            start, _, stop = self.check_run(list(events))
            self.assertEqual(start["continues"], doc["uid"])
            self.assertEqual(stop["exit_status"], "success")
            cap = gonio.read_capture(os.path.join(self.d.root, "pr"))
            self.assertEqual(sorted(cap.samples["point"]), list(range(start["num_points"])))

    def test_refusals(self):
        with self.client() as client:
            for fields, code in (({"sideways": 1}, "unknown-field"),
                                 ({"budget": "1"}, "bad-type"), ({"prescan": 1.5}, "bad-type")):
                with self.assertRaises(gonio.GonioError) as e:
                    client.capture("ds3", **fields)
                self.assertEqual(e.exception.code, code)
            # Every field the client takes is one goniod knows: sent past
            # the client's own check with a value of no field's type, each is
            # refused as bad-type, never unknown-field.
            for name in gonio.CAPTURE_FIELDS:
                with self.assertRaises(gonio.GonioError) as e:
                    client.request("capture", **dict({"plan": "ds3"}, **{name: [1]}))
                self.assertEqual((name, e.exception.code), (name, "bad-type"))
            # The client passes a check on; goniod refuses it on a rig that cannot turn the sample.
            with self.assertRaises(gonio.GonioError) as e:
                client.capture("ds3", check="isotropy")
            self.assertEqual(e.exception.code, "bad-value")
            self.assertIn("rig 'default' has no rotation axis", e.exception.message)
            with self.assertRaises(gonio.GonioError) as e:
                client.capture("nosuch")
            self.assertEqual(e.exception.code, "bad-value")
            self.assertIn("nosuch", e.exception.message)
            with self.assertRaises(gonio.GonioError) as e:
                client.watch(format="xml")
            self.assertEqual(e.exception.code, "bad-value")
            self.assertEqual(client.status()["state"], "idle")
        with self.assertRaises(ValueError) as e:
            gonio.Model(os.path.join(self.folder, "nothing.model"))
        self.assertIn("nothing.model", str(e.exception))

    def test_docs_example(self):
        """docs/python.md's example cells, run in order in one namespace."""
        with open(os.path.join(SOURCE, "docs", "python.md")) as f:
            text = f.read()
        cells = re.findall(r"```python\n(.*?)```", text, re.S)
        self.assertGreaterEqual(len(cells), 3)
        os.environ["GONIO_SOCKET"] = self.d.sock
        try:
            ns = {}
            for cell in cells:
                exec(compile(cell, "docs/python.md", "exec"), ns)
        finally:
            del os.environ["GONIO_SOCKET"]
        cap = ns["cap"]
        self.assertEqual(os.path.realpath(cap.dir),
                         os.path.realpath(os.path.join(self.d.root, "nylon-ds4")))
        self.assertGreater(len(ns["seen"]), 0)
        self.assertAlmostEqual(sum(ns["terms"]) / len(ns["terms"]),
                               cap.results["errors"]["plan"]["log"], places=9)


class ClientListTests(Checks, DaemonTest):
    """Client.list, where goniod has the list command (skipped, visibly,
    where it has not)."""

    def client(self):
        return gonio.Client(self.d.sock, timeout=2 * START_S)

    def test_list(self):
        with self.client() as client:
            try:
                client.request("list")
            except gonio.GonioError as e:
                if e.code != "unknown-command":
                    raise
                self.skipTest("goniod has no list command (SKIPPED: Client.list)")
            list(self.follow(client, "ds4", name="ls")[1])
            ids = [c.get("id", c.get("capture_id")) for c in client.list()]
            self.assertIn("ls", ids)


class ClientModbusTests(Checks, ModbusRig):
    def test_capture_over_modbus_tcp(self):
        """goniod over Modbus TCP to gonio-sim: the data keys name the bus,
        slave and register each field comes from."""
        self.d = Daemon(self.folder, driver=self.tcp_driver(1000)).start()
        with gonio.Client(self.d.sock) as client:
            reply, pairs, cap = self.follow(client, "ds3", name="mb")
        start, streams, stop = self.check_capture(pairs, cap)
        keys = streams["primary"][0]["data_keys"]
        bus = "modbus-tcp:127.0.0.1:%d" % self.port
        self.assertEqual(keys["s"]["source"], bus + " slave 1 register 0xCC (feedback position)")
        self.assertEqual(keys["a"]["source"], bus + " slave 2 register 0xCC (feedback position)")
        self.assertEqual(keys["rgb"]["source"], bus + " slave 3 register 0x0C (channels)")
        self.assertEqual(streams["primary"][0]["configuration"]["driver"]["data"]["port"],
                         self.port)


if __name__ == "__main__":
    unittest.main()
