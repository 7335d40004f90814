"""gonio-sim's AZ drive outputs, read by the RTU master of conftest.py (not
the C drivers): with a jittered scene and a 0.05 deg positioning
completion band (--in-pos-deg), a move that has ended turns IN-POS on
exactly when the encoder rests within the band of the target, READY on
and MOVE off either way; while it moves MOVE is on and READY and IN-POS
are off (docs/protocol-modbus.md, the AZ manual's IN-POS output)."""
import os
import shutil
import signal
import subprocess
import time

import pytest

from conftest import RtuMaster, TIME_SCALE, gonio_bin, tg

READY, MOVE, IN_POS = 1 << 5, 1 << 13, 1 << 14
CLOCK = 0x0A  # the detector's rig clock, ms
BAND = 0.05
SCENE = """name: jittery
material: default
rig: default
detector: {kind: rgb}
seed: 5
effects:
  - {name: jitter, sigma_deg: 0.05, axes: [sample]}
"""


@pytest.fixture
def jittery():
    pytest.importorskip("serial")
    folder = tg.tmpdir()
    scene = os.path.join(folder, "jittery.yaml")
    with open(scene, "w") as f:
        f.write(SCENE)
    proc = subprocess.Popen(tg.wrap([os.path.join(gonio_bin(), "gonio-sim"), "--scene", scene,
                                     "--time-scale", str(TIME_SCALE), "--in-pos-deg",
                                     str(BAND)], folder), stdout=subprocess.PIPE, text=True,
                            preexec_fn=tg.child_procs.die_with_parent)
    try:
        pty = proc.stdout.readline().strip()
        m = RtuMaster(pty)
        yield m
        m.close()
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=2 * tg.START_S) == 0
        tg.assert_valgrind_clean(folder)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        shutil.rmtree(folder, ignore_errors=True)


def start(m, steps):
    """Absolute move of the sample (slave 1) at 20 deg/s, 40 deg/s^2."""
    m.write32(1, 0x58, [0, 1, steps, 2000, 4000, 4000, 1000, 1])


def test_in_pos_band(jittery):
    m = jittery
    inside = outside = watched = 0
    at = 0
    for i in range(1, 31):
        target = (-1) ** i * (30 + i)  # 60 deg: 3.5 s of rig time, 70 ms of wall
        # the trapezoid (over 10 deg: it cruises), less 50 ms for the jitter
        # (sigma 0.05 deg: 2.5 ms at 20 deg/s) that may end it sooner
        ends_s = abs(target - at) / 20 + 20 / 40 - 0.05
        t0 = m.read32(3, CLOCK)
        start(m, target * 100)
        st = m.read32(1, 0x7E)
        # The status was read while the move ran if the rig clock after it
        # is short of the move's end (a host that held the test longer let
        # the move end first: that move's status says nothing of MOVE).
        if m.read32(3, CLOCK) - t0 < 1000 * ends_s:
            assert st & MOVE and not st & READY and not st & IN_POS, hex(st)
            watched += 1
        deadline = time.monotonic() + 2 * tg.START_S
        while st & MOVE and time.monotonic() < deadline:
            time.sleep(0.002)
            st = m.read32(1, 0x7E)
        at = m.read32(1, 0xCC, signed=True) / 100
        assert st & READY and not st & MOVE, hex(st)
        assert bool(st & IN_POS) == (abs(at - target) <= BAND + 1e-9), (hex(st), at, target)
        inside += abs(at - target) <= BAND
        outside += abs(at - target) > BAND
    assert inside and outside  # the jitter puts the drive on both sides of its band
    assert watched  # MOVE, READY and IN-POS seen during a move
