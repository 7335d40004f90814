#!/usr/bin/python3
"""goniod's event-model documents (watch with format event-model;
docs/protocol.md): every document of captures in each order, an aborted, a
failed and a resumed one validated against Bluesky's published schemas
(../shared/anchors/event-model) with python3-jsonschema, their uid,
run_start and descriptor references followed, and their data compared with
the capture's journal.

Run from ctest (the environment names the binaries), or by hand:
  GONIO_BIN=build/bin GONIO_TESTS_BIN=build/tests GONIO_CONFIG=configs \\
      python3 tests/daemon/test_goniod_events.py -v
"""
import json
import os
import sys
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from gonio_cal_events import validators as load_validators  # noqa: E402
from goniod_harness import DaemonTest, read_samples  # noqa: E402

DTYPES = {"number": (int, float, type(None)), "integer": (int,), "boolean": (bool,),
          "string": (str,), "array": (list,)}


def read_run(conn):
    """The [name, doc] pairs of one run, up to and including its stop."""
    docs = []
    while True:
        d = conn.read()
        if d is None:
            raise AssertionError("stream ended before stop: %r" % docs[-3:])
        if isinstance(d, dict):  # a reply (OK) on the watching connection
            continue
        docs.append(tuple(d))
        if d[0] == "stop":
            return docs


class EventModelTests(DaemonTest):
    pace_s = 0.02

    def setUp(self):
        self.validators, why = load_validators()
        if self.validators is None:
            self.skipTest(why)
        super().setUp()

    def check_run(self, pairs, joined_late=False):
        """Every document valid, the references consistent (of a watcher
        that joined_late, the primary events from the one it joined at, in
        sequence to the end); returns
        (start, {stream name: (descriptor, [events])}, stop)."""
        for name, doc in pairs:
            errors = [e.message for e in self.validators[name].iter_errors(doc)]
            self.assertEqual(errors, [], "%s invalid: %s" % (name, json.dumps(doc)[:600]))
        names = [n for n, _ in pairs]
        self.assertEqual(names[0], "start")
        self.assertEqual(names[-1], "stop")
        self.assertEqual(names.count("start"), 1)
        self.assertEqual(names.count("stop"), 1)
        start, stop = pairs[0][1], pairs[-1][1]
        uids = [d["uid"] for _, d in pairs]
        self.assertEqual(len(set(uids)), len(uids), "uids repeat")
        streams, by_uid = {}, {}
        for name, doc in pairs[1:-1]:
            if name == "descriptor":
                self.assertEqual(doc["run_start"], start["uid"])
                self.assertNotIn(doc["name"], streams)
                streams[doc["name"]] = (doc, [])
                by_uid[doc["uid"]] = doc["name"]
            else:
                self.assertEqual(name, "event")
                self.assertIn(doc["descriptor"], by_uid, "event before its descriptor")
                desc, events = streams[by_uid[doc["descriptor"]]]
                if events or not joined_late:
                    first = events[0]["seq_num"] if events else 1
                    self.assertEqual(doc["seq_num"], first + len(events))
                keys = desc["data_keys"]
                self.assertEqual(set(doc["data"]), set(keys))
                self.assertEqual(set(doc["timestamps"]), set(keys))
                for k, v in doc["data"].items():
                    self.assertIsInstance(v, DTYPES[keys[k]["dtype"]], k)
                    if keys[k]["shape"]:
                        self.assertEqual([len(v)], keys[k]["shape"], k)
                events.append(doc)
        self.assertEqual(stop["run_start"], start["uid"])
        self.assertEqual(stop["num_events"],
                         {n: (e[-1]["seq_num"] if joined_late else len(e))
                          for n, (_, e) in streams.items()})
        return start, streams, stop

    def check_against_journal(self, capture_id, events):
        """Each event's rgb is its point's in samples.csv."""
        rgb = read_samples(os.path.join(self.d.root, capture_id, "samples.csv"))
        self.assertGreater(len(events), 0)
        for e in events:
            self.assertEqual(e["data"]["rgb"], rgb[e["data"]["point"]])

    def capture(self, conn, **req):
        r = conn.request("capture", **req)
        self.assertEqual(r["class"], "OK", r)
        return self.check_run(read_run(conn))

    def test_each_order(self):
        """travel, progressive with the converge stop, adaptive: valid runs,
        the primary stream's data keys naming their source and units, the
        rig in the descriptor's configuration, the fit in a second stream;
        the stream watcher alongside gets its own documents unchanged."""
        c = self.d.connect()
        self.assertEqual(c.request("watch", format="event-model")["class"], "OK")
        plain = self.d.connect()
        self.assertEqual(plain.request("watch")["class"], "OK")
        runs = (("tr", dict(plan="ds3", order="travel")),
                ("pc", dict(plan="ds3", order="progressive", stop="converge")),
                ("ad", dict(plan="ds2", order="adaptive", budget=1)))
        for name, req in runs:
            start, streams, stop = self.capture(c, name=name, **req)
            self.assertEqual((start["capture_id"], start["plan"]), (name, req["plan"]))
            self.assertIsNone(start["continues"])
            self.assertEqual(stop["exit_status"], "success", stop)
            desc, events = streams["primary"]
            self.check_against_journal(name, events)
            keys = desc["data_keys"]
            self.assertEqual((keys["rgb"]["dtype"], keys["rgb"]["shape"], keys["rgb"]["units"]),
                             ("array", [3], "1/sr"))
            self.assertEqual(keys["s"]["source"], "gonio-sim:sample axis position")
            self.assertEqual(keys["theta_r"]["units"], "deg")
            rig = desc["configuration"]["rig"]
            self.assertEqual(rig["data"]["name"], "default")
            self.assertEqual(set(rig["data_keys"]), set(rig["data"]))
            self.assertEqual(desc["configuration"]["driver"]["data"]["kind"], "sim")
            adaptive = req["order"] == "adaptive"
            self.assertEqual("predicted_error" in keys, adaptive)
            self.assertEqual("fit_log_error" in keys, not adaptive)
            fit_desc, fit_events = streams["fit"]
            self.assertEqual(len(fit_events), 1)
            with open(os.path.join(self.d.root, name, "results.json")) as f:
                results = json.load(f)
            fit = fit_events[0]["data"]
            self.assertEqual(fit["model"], "abc")
            self.assertAlmostEqual(fit["plan_log_error"], results["errors"]["plan"]["log"],
                                   places=6)
            self.assertEqual(fit["samples"], results["samples"])
            # the stream format is unchanged beside it
            classic = [d for d in _until_stop(plain)]
            self.assertEqual(classic[0]["class"], "start")
            self.assertEqual(sum(d["class"] == "event" for d in classic), len(events))
            self.assertEqual(classic[-1]["samples"], stop["num_events"]["primary"])
        self.assertEqual(start["adaptive"], True)

    def test_abort_resume_and_failure(self):
        """An aborted run, its resume (a new run naming the one it
        continues), and a run that fails at once on a corrupt journal."""
        c = self.d.connect()
        c.request("watch", format="event-model")
        # requests sent without waiting: read_run keeps every pair that
        # comes before the reply
        c.send({"cmd": "capture", "plan": "ds3", "name": "ab"})
        first = until_event(c)
        c.send({"cmd": "abort"})
        start1, streams1, stop1 = self.check_run(first + read_run(c))
        self.assertEqual((stop1["exit_status"], stop1["reason"]), ("abort", "aborted"))
        self.assertNotIn("fit", streams1)
        # a watcher arriving now hears nothing of the ended run
        late = self.d.connect()
        self.assertEqual(late.request("watch", format="event-model")["class"], "OK")
        self.assertEqual(c.request("resume", capture_id="ab")["class"], "OK")
        start2, streams2, stop2 = self.check_run(read_run(c))
        self.assertEqual(stop2["exit_status"], "success")
        self.assertNotEqual(start2["uid"], start1["uid"])
        self.assertEqual(start2["continues"], start1["uid"])
        self.assertIs(start2["resume"], True)
        self.assertEqual(start2["already_done"], stop1["num_events"]["primary"])
        self.assertEqual(len(streams2["primary"][1]) + start2["already_done"],
                         start2["num_points"])
        self.assertEqual(read_run(late)[0][1]["uid"], start2["uid"])
        with open(os.path.join(self.d.root, "ab", "run-uids.txt")) as f:
            self.assertEqual(f.read().split(), [start1["uid"], start2["uid"]])
        # a corrupt journal: the resumed run fails before its first point
        c.send({"cmd": "capture", "plan": "ds3", "name": "bad"})
        first = until_event(c)
        c.send({"cmd": "abort"})
        start3 = self.check_run(first + read_run(c))[0]
        journal = os.path.join(self.d.root, "bad", "samples.csv")
        with open(journal) as f:
            lines = f.read().splitlines(True)
        lines[1] = "garbage,not,a,sample\n"
        with open(journal, "w") as f:
            f.writelines(lines)
        self.assertEqual(c.request("resume", capture_id="bad")["class"], "OK")
        start4, streams4, stop4 = self.check_run(read_run(c))
        self.assertEqual(stop4["exit_status"], "fail", stop4)
        self.assertIn("samples.csv", stop4["reason"])
        self.assertEqual(start4["continues"], start3["uid"])
        self.assertEqual(stop4["num_events"], {n: len(e) for n, (_, e) in streams4.items()})

    def test_late_watcher_and_bad_format(self):
        """A watcher that subscribes mid-run gets the run's start and
        descriptor first; an unknown format is refused."""
        c = self.d.connect()
        r = c.request("watch", format="xml")
        self.assertEqual((r["class"], r["code"]), ("ERROR", "bad-value"), r)
        self.assertIn("'xml'", r["message"])
        self.assertEqual(c.request("watch", format=1)["code"], "bad-type")
        c.request("watch", format="event-model")
        c.send({"cmd": "capture", "plan": "ds3", "name": "lw"})
        head = until_event(c)
        c.send({"cmd": "pause"})  # held while the late watcher joins
        late = self.d.connect()
        late.request("watch", format="event-model")
        self.assertEqual(self.d.connect().request("resume")["class"], "OK")
        pairs = read_run(late)
        self.assertEqual([n for n, _ in pairs[:2]], ["start", "descriptor"])
        self.assertEqual(pairs[0][1], head[0][1])
        self.assertEqual(pairs[1][1], head[1][1])
        self.check_run(pairs, joined_late=True)
        self.check_run(head + read_run(c))


def until_event(conn):
    """The pairs up to and including the first event (replies skipped)."""
    pairs = []
    while not pairs or pairs[-1][0] != "event":
        d = conn.read()
        if d is None:
            raise AssertionError("stream ended before an event")
        if isinstance(d, list):
            pairs.append(tuple(d))
    return pairs


def _until_stop(conn):
    docs = []
    while True:
        d = conn.read()
        if isinstance(d, dict) and d.get("class") in ("start", "descriptor", "event", "stop",
                                                      "state"):
            docs.append(d)
            if d["class"] == "stop":
                return docs


if __name__ == "__main__":
    unittest.main()
