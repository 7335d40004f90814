"""The detector's raw mode as an independent master sees it (the hand-built
RTU master of conftest.py, docs/protocol-modbus.md "Raw mode"): gonio-sim on
the lab scene sets RAW, publishes uint32 counts between the ADC's offset
and full scale with the raw block of the same reading, and its shutter
leaves offset and dark; the calibrated scene leaves RAW clear; the gap
between the channels and the raw block is unmapped."""
import math
import struct

import pytest

from conftest import RtuMaster, TIME_SCALE, gonio_sim
from test_rtu import DETECTOR, exception

STATUS, SEQUENCE, CHANNELS = 0x04, 0x08, 0x0C
RAW_SEQUENCE, GAIN, FULL, NONLINEARITY, MONITOR, SHUTTER = (0x100, 0x102, 0x104, 0x106, 0x108,
                                                            0x10A)
BUSY, READY, SATURATED, RAW = 1, 2, 4, 8
T_US = 62500  # integration, us


def acquire(m):
    """Trigger one integration of T_US and wait for its data: the status."""
    seq0 = m.read32(DETECTOR, SEQUENCE)
    m.write32(DETECTOR, 0x00, [T_US, 1])
    for _ in range(2000):
        st = m.read32(DETECTOR, STATUS)
        if st & READY and m.read32(DETECTOR, SEQUENCE) == seq0 + 1:
            return st
    raise AssertionError("no fresh reading")


def counts(m):
    return [m.read32(DETECTOR, CHANNELS + 2 * k) for k in range(3)]


@pytest.fixture(scope="module")
def raw_sim():
    pytest.importorskip("serial")
    with gonio_sim("--scene", "lab", "--time-scale", str(TIME_SCALE)) as s:
        m = RtuMaster(s["pty"])
        yield m
        m.close()


def test_raw_block(raw_sim):
    m = raw_sim
    st = acquire(m)
    assert st & RAW and not st & BUSY
    assert m.read32(DETECTOR, RAW_SEQUENCE) == m.read32(DETECTOR, SEQUENCE)
    assert m.read32(DETECTOR, GAIN) == 0
    full = m.read32(DETECTOR, FULL)
    assert full == 65535
    k = struct.unpack(">f", struct.pack(">I", m.read32(DETECTOR, NONLINEARITY)))[0]
    assert k == pytest.approx(0.02, rel=1e-7)
    mon = m.read32(DETECTOR, MONITOR)  # 1e7 counts/s over 62.5 ms, Poisson
    assert abs(mon - 625000) < 5 * math.sqrt(625000) + 0.02 * 625000  # lamp drift 0.5 %
    c = counts(m)
    assert all(1000 < v <= full for v in c), c
    assert bool(st & SATURATED) == any(v == full for v in c)
    assert m.read32(DETECTOR, 0x00) == T_US  # the capture's integration, no auto-exposure


def test_shutter_leaves_offset_and_dark(raw_sim):
    m = raw_sim
    m.write32(DETECTOR, SHUTTER, [5])  # any nonzero closes
    assert m.read32(DETECTOR, SHUTTER) == 1
    seen = []
    for _ in range(10):
        assert acquire(m) & RAW
        seen += counts(m)
    # offset + 0.8 ADU/e- x 500 e-/s x 62.5 ms = 1025 ADU; sd 0.8 sqrt(31 + 144) = 10.6
    mean = sum(seen) / len(seen)
    assert abs(mean - 1025) < 4 * 10.6 / math.sqrt(len(seen)), seen
    m.write32(DETECTOR, SHUTTER, [0])
    assert m.read32(DETECTOR, SHUTTER) == 0
    acquire(m)
    assert min(counts(m)) > 1025 + 10 * 10.6  # the light is back


def test_calibrated_scene_is_not_raw(rtu):
    st = acquire(rtu)
    assert st & READY and not st & RAW
    assert exception(rtu, DETECTOR, bytes([0x03, 0, 0x12, 0, 2])) == 0x02
    assert exception(rtu, DETECTOR, bytes([0x03, 0, 0xFE, 0, 4])) == 0x02  # runs into the gap
    assert exception(rtu, DETECTOR, bytes([0x10, 0x01, 0x04, 0, 2, 4, 0, 0, 0, 1])) == 0x02
