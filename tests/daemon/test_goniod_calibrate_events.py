#!/usr/bin/python3
"""A calibration through goniod is a run of event-model documents as a capture
is (docs/protocol.md, "Calibrations as event-model documents"), on gonio-sim's
raw lab scene over Modbus TCP (the rig of test_goniod_calibrate.py):

- a dark and a reference: every document valid against Bluesky's schemas
  (../shared/anchors/event-model), an event per frame equal to frames.csv,
  the results stream the frames' means and spreads, the start naming the
  calibration (id, kind, rig, detector, validity) and the dark's run; the
  watcher gets what the calibration's documents.jsonl holds;
- a reference aborted while it waits on the operator: its run ends abort,
  and gonio resume ID is a new run that continues it;
- a capture reduced with the reference: its run_start names the
  calibration and that calibration's run.
"""
import os
import subprocess
import sys
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import child_procs  # noqa: E402
import gonio_cal_events as ev  # noqa: E402
from goniod_harness import GONIO, START_S  # noqa: E402
from test_goniod_calibrate import SAMPLE, CalibrateRig  # noqa: E402
from test_goniod_events import read_run  # noqa: E402


class CalibrateEventsTests(CalibrateRig):

    def setUp(self):
        self.v, why = ev.validators()
        if self.v is None:
            self.skipTest(why)
        super().setUp()

    def check(self, run, cal_id):
        """run checked against its calibration and against what goniod
        wrote to documents.jsonl (the run is the file's last)."""
        cal_dir = os.path.join(self.cal_root, cal_id)
        on_disk = ev.read_documents(cal_dir)
        self.assertEqual([list(p) for p in run], [list(p) for p in on_disk[-len(run):]])
        return ev.check_run(run, cal_dir, self.v)

    def test_calibration_runs_and_the_capture_names_its_calibration(self):
        self.start_daemon()
        w = self.d.connect()
        self.assertEqual(w.request("watch", format="event-model")["class"], "OK")
        dark_id, ref_id = self.dark_and_reference()
        dark_start, dark_stop, streams = self.check(read_run(w), dark_id)
        self.assertEqual((dark_start["kind"], dark_start["rig"], dark_start["detector"]),
                         ("dark", "lab", "modbus"))
        self.assertEqual(dark_stop["num_events"], {"primary": 16, "results": 1})
        counts = streams["primary"][0]["data_keys"]["counts"]
        self.assertEqual(counts["source"], "modbus-tcp:127.0.0.1:%d slave 3 register 0x0C "
                         "(channels)" % self.port)
        self.assertEqual((counts["shape"], counts["units"]), ([3], "ADU"))
        ref_start, ref_stop, streams = self.check(read_run(w), ref_id)
        self.assertEqual((ref_start["kind"], ref_start["dark"], ref_start["dark_uid"]),
                         ("reference", dark_id, dark_start["uid"]))
        self.assertEqual((ref_stop["exit_status"], ref_stop["num_events"]),
                         ("success", {"primary": 104, "results": 52}))

        # Aborted while it waits for the standard: a run that ends abort,
        # then gonio resume ID, a run that continues it.
        env = dict(self.d.env, GONIO_SOCKET=self.d.sock)
        p = subprocess.Popen([GONIO, "calibrate", "reference", "--plan", "ds3", "--repeats",
                              "2", "--name", "ref-cut"], stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, text=True, env=env,
                             preexec_fn=child_procs.die_with_parent)
        self.wait_state("paused", "asking for the standard")
        self.assertEqual(self.d.gonio("abort").returncode, 0)
        p.communicate(timeout=30 * START_S)  # a hang, not a slow host
        cut_start, cut_stop, streams = self.check(read_run(w), "ref-cut")
        self.assertEqual((cut_stop["exit_status"], cut_stop["reason"]), ("abort", "aborted"))
        self.assertEqual((streams, cut_start["continues"]), ({}, None))
        self.assertEqual(self.d.gonio("resume", "ref-cut").returncode, 0)
        self.wait_state("paused", "asking again")
        self.assertEqual(self.d.gonio("resume").returncode, 0)
        start, stop, _ = self.check(read_run(w), "ref-cut")
        self.assertEqual((start["continues"], stop["exit_status"]), (cut_start["uid"], "success"))

        # The operator mounts the sample; the capture names its calibration.
        self.start_sim(SAMPLE)
        r = self.d.gonio("capture", "--plan", "ds3", "--name", "cap", "--calibration", ref_id,
                         "--wait", "--quiet")
        self.assertEqual(r.returncode, 0, r.stderr + r.stdout)
        run = read_run(w)
        self.assertEqual(run[0][0], "start")
        errors = [e.message for e in self.v["start"].iter_errors(run[0][1])]
        self.assertEqual(errors, [])
        self.assertEqual((run[0][1]["calibration"], run[0][1]["calibration_uid"]),
                         (ref_id, ref_start["uid"]))


if __name__ == "__main__":
    unittest.main()
