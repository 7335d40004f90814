"""gonio-sim's simulated clock seen by an independent master (pyserial):
the status bits say which clock runs, the clock stands still while the
host waits, a poll for a move's or an integration's end finds it ended
with the clock at that end, the wait register passes exactly what is
written and takes no line time, and the line's frames are counted
(docs/gonio-sim.md, "The simulated clock"; docs/protocol-modbus.md)."""
import time

import pytest

from conftest import RtuMaster, gonio_sim

DET, ARM = 3, 2
STATUS, CLOCK, WAIT = 0x0004, 0x000A, 0x0200
CLOCK_SIMULATED, LINE_TIMED = 1 << 15, 1 << 14
AX_DIRECT, AX_STATUS, MOVE = 0x0058, 0x007E, 1 << 13
STEPS = 100  # gonio-sim's default steps per degree


def master(*args):
    pytest.importorskip("serial")
    return gonio_sim(*args)


def clock_ms(m):
    return m.read32(DET, CLOCK)


def test_wall_clock_has_neither_bit_nor_wait():
    with master("--time-scale", "10") as s:
        m = RtuMaster(s["pty"])
        try:
            assert m.read32(DET, STATUS) & (CLOCK_SIMULATED | LINE_TIMED) == 0
            body = bytes([0x10, WAIT >> 8, WAIT & 0xFF, 0, 2, 4, 0, 0, 0, 1])
            assert m.request(DET, body) == bytes([0x90, 0x02])  # unmapped
        finally:
            m.close()


def test_simulated_clock_counts_only_what_it_models():
    with master("--clock", "simulated") as s:
        m = RtuMaster(s["pty"])
        try:
            assert m.read32(DET, STATUS) & (CLOCK_SIMULATED | LINE_TIMED) == CLOCK_SIMULATED
            t0 = clock_ms(m)
            time.sleep(0.3)  # the host's time is not the rig's
            assert clock_ms(m) == t0
            m.write32(DET, WAIT, [2_500_000])  # 2.5 s of rig time, at once
            assert clock_ms(m) == t0 + 2500
            # The arm to 40 deg at the profile's 15 deg/s, 30 deg/s^2: 40/15 + 15/30 s.
            m.write32(ARM, AX_DIRECT, [0, 1, 40 * STEPS, 15 * STEPS, 30 * STEPS, 30 * STEPS,
                                       1000, 1])
            t1 = clock_ms(m)
            assert t1 == t0 + 2500  # the move runs on, the clock stands
            assert m.read32(ARM, AX_STATUS) & MOVE == 0  # the poll finds it ended
            assert clock_ms(m) == t1 + round(1000 * (40 / 15 + 15 / 30))
            # An integration of 0.25 s: BUSY never seen, the clock at its end.
            t2 = clock_ms(m)
            m.write32(DET, 0x0000, [250_000, 1])
            assert m.read32(DET, STATUS) & 0b11 == 0b10  # READY, not BUSY
            assert clock_ms(m) == t2 + 250
        finally:
            m.close()


def test_line_timed_clock_counts_the_frames():
    # 9600 baud: 11 bits a character, t3.5 of 3.5 characters after each frame.
    with master("--clock", "simulated", "--baud", "9600") as s:
        m = RtuMaster(s["pty"], 9600)
        try:
            assert m.read32(DET, STATUS) & LINE_TIMED
            ch = 11 / 9600
            t0 = clock_ms(m)
            # The clock read itself: its request (8 characters) and t3.5 pass
            # before the register is read; its reply's time, after.
            t1 = clock_ms(m)
            exchange = (8 + 3.5 + 9 + 3.5) * ch
            assert abs((t1 - t0) * 1e-3 - exchange) <= 1.5e-3
            # The wait takes no line time: exactly what was written passes.
            m.write32(DET, WAIT, [1_000_000])
            t2 = clock_ms(m)
            assert abs((t2 - t1) * 1e-3 - 1.0 - exchange) <= 1.5e-3
        finally:
            m.close()
