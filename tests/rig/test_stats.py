"""gonio-sim --stats counts the exchanges with each present device (what
make bench reports per point): requests to the detector and to one axis,
and one to an absent slave, which is no exchange."""
import json
import os
import shutil
import tempfile

import pytest

from conftest import RtuMaster, frame, gonio_sim

SAMPLE, DETECTOR = 1, 3


def test_exchanges_per_device():
    pytest.importorskip("serial")
    folder = tempfile.mkdtemp(prefix="rig-stats")
    stats = os.path.join(folder, "stats.json")
    try:
        with gonio_sim("--stats", stats) as s:
            m = RtuMaster(s["pty"])
            try:
                for _ in range(3):
                    m.read(DETECTOR, 0x06, 2)
                for _ in range(2):
                    m.read(SAMPLE, 0x7E, 2)
                assert m.raw(frame(bytes([9, 0x03, 0, 0x7E, 0, 2])), timeout=0.2) is None
            finally:
                m.close()
        with open(stats) as f:  # written as gonio-sim exits
            doc = json.load(f)
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    assert doc["exchanges"] == 5
    assert doc["detector"]["exchanges"] == 3
    assert [doc["axes"][a]["exchanges"] for a in ("sample", "arm", "azimuth")] == [2, 0, 0]
