"""gonio-sim as a Modbus RTU slave, driven by the hand-built master of
conftest.py over its pseudo-terminal: framing and CRC, exceptions, silence
on bad frames and absent slaves, motion on the trapezoid at the simulated
clock, homing, soft-limit alarm and reset (docs/protocol-modbus.md)."""
import math
import time

import pytest

from conftest import RtuMaster, TIME_SCALE, crc16, frame, gonio_sim

SAMPLE, ARM, DETECTOR, AZIMUTH = 1, 2, 3, 4
DIRECT, INPUT, STATUS, ALARM, FEEDBACK = 0x58, 0x7C, 0x7E, 0x80, 0xCC
ZHOME, STOP, ALM_RST = 1 << 4, 1 << 5, 1 << 7
HOME_END, READY, ALM_A, MOVE, IN_POS = 1 << 4, 1 << 5, 1 << 7, 1 << 13, 1 << 14
CLOCK, WAIT = 0x0A, 0x0200
STEPS = 100  # steps per degree (gonio-sim's default)


def clock(m):
    return m.read32(DETECTOR, CLOCK) / 1000.0


def start(m, slave, deg, speed_deg, accel_deg):
    m.write32(slave, DIRECT, [0, 1, round(deg * STEPS), round(speed_deg * STEPS),
                              round(accel_deg * STEPS), round(accel_deg * STEPS), 1000, 1])


def wait_status(m, slave, bits, wall_timeout=3.0):
    deadline = time.monotonic() + wall_timeout
    while time.monotonic() < deadline:
        st = m.read32(slave, STATUS)
        if st & bits == bits and not st & MOVE:
            return st
        time.sleep(0.001)
    raise AssertionError("slave %d: status bits 0x%x not reached" % (slave, bits))


def move(m, slave, deg):
    start(m, slave, deg, 20, 40)
    wait_status(m, slave, IN_POS)
    assert m.read32(slave, FEEDBACK, signed=True) == round(deg * STEPS)


def trapezoid(dist, v, a, t):
    """Distance covered t seconds into a rest-to-rest move: accelerate at a,
    cruise at v, decelerate at a (triangular when too short for v)."""
    if dist <= 0 or t <= 0:
        return 0.0
    if dist < v * v / a:
        v = math.sqrt(dist * a)
    t_acc = v / a
    total = dist / v + t_acc
    if t >= total:
        return dist
    if t < t_acc:
        return 0.5 * a * t * t
    if t < total - t_acc:
        return 0.5 * a * t_acc * t_acc + v * (t - t_acc)
    r = total - t
    return dist - 0.5 * a * r * r


def test_crc_of_the_specification_example():
    # The Modbus over serial line guide's example: 01 03 00 00 00 0A -> C5 CD.
    assert frame(bytes.fromhex("01030000000A")).hex() == "01030000000ac5cd"
    assert crc16(bytes.fromhex("01030000000A")) == 0xCDC5


def test_reply_is_well_formed(rtu):
    reply = rtu.raw(frame(bytes([SAMPLE, 0x03, 0, STATUS, 0, 2])))
    assert reply is not None and len(reply) == 9
    assert reply[:3] == bytes([SAMPLE, 0x03, 4])
    assert crc16(reply[:-2]) == reply[-2] | (reply[-1] << 8)
    # Channel count 3 on the detector, as the map says.
    assert rtu.read32(DETECTOR, 0x06) == 3


def exception(rtu, slave, pdu):
    reply = rtu.request(slave, pdu)
    assert reply is not None and len(reply) == 2, reply
    assert reply[0] == pdu[0] | 0x80
    return reply[1]


def test_exceptions(rtu):
    # Unmapped register, on an axis and past the detector's three channels.
    assert exception(rtu, SAMPLE, bytes([0x03, 0, 0, 0, 1])) == 0x02
    assert exception(rtu, SAMPLE, bytes([0x03, 0, 0x7E, 0, 5])) == 0x02  # runs into a hole
    assert exception(rtu, DETECTOR, bytes([0x03, 0, 0x10, 0, 8])) == 0x02
    # Read-only registers refuse writes.
    assert exception(rtu, SAMPLE, bytes([0x06, 0, STATUS, 0, 1])) == 0x02
    assert exception(rtu, DETECTOR, bytes([0x10, 0, 0x04, 0, 1, 2, 0, 1])) == 0x02
    # Functions outside 0x03, 0x06, 0x10.
    assert exception(rtu, SAMPLE, bytes([0x01, 0, 0, 0, 1])) == 0x01
    assert exception(rtu, SAMPLE, bytes([0x04, 0, STATUS, 0, 2])) == 0x01
    # Bad quantities and byte counts.
    assert exception(rtu, SAMPLE, bytes([0x03, 0, STATUS, 0, 0])) == 0x03
    assert exception(rtu, SAMPLE, bytes([0x03, 0, STATUS, 0, 126])) == 0x03
    assert exception(rtu, SAMPLE, bytes([0x10, 0, DIRECT, 0, 2, 3, 0, 0, 0])) == 0x03
    # The slave still answers normally afterwards.
    assert rtu.read32(SAMPLE, ALARM) == 0


def test_no_answer_to_bad_crc_or_absent_slave(rtu):
    good = frame(bytes([SAMPLE, 0x03, 0, STATUS, 0, 2]))
    bad = good[:-1] + bytes([good[-1] ^ 0x01])
    assert rtu.raw(bad, timeout=0.2) is None
    assert rtu.raw(frame(bytes([9, 0x03, 0, STATUS, 0, 2])), timeout=0.2) is None
    # Line noise, then silence: ignored too.
    assert rtu.raw(bytes([0x55, 0xAA, 0x00, 0x13]), timeout=0.2) is None
    reply = rtu.raw(good)
    assert reply is not None and reply[:3] == bytes([SAMPLE, 0x03, 4])


def test_move_follows_the_trapezoid():
    """60 deg at 2 deg/s and 4 deg/s^2 (not the profile's 15 and 30): the
    drive runs at what it is told. On a gonio-sim of its own on the
    simulated clock, so the instants the position is read at are the rig's,
    not the host's: every half second of rig time (the wait register) the
    position lies on the trapezoid to a step, and a status read passes the
    clock to the move's end at T = 60/2 + 2/4 = 30.5 s, with IN-POS."""
    pytest.importorskip("serial")
    dist, v, a = 60.0, 2.0, 4.0
    total = dist / v + v / a
    with gonio_sim("--clock", "simulated") as s:
        m = RtuMaster(s["pty"])
        try:
            t0 = clock(m)
            start(m, ARM, dist, v, a)
            assert clock(m) == t0  # no line time: the move starts at t0
            positions = []
            for k in range(1, int(total / 0.5)):
                m.write32(DETECTOR, WAIT, [500_000])
                t = clock(m) - t0
                assert abs(t - 0.5 * k) < 1e-9
                pos = m.read32(ARM, FEEDBACK, signed=True) / STEPS
                assert abs(pos - trapezoid(dist, v, a, t)) <= 0.01 + 1e-9, (t, pos)
                positions.append(pos)
            assert positions == sorted(positions) and 0 < positions[0] < positions[-1] < dist
            st = m.read32(ARM, STATUS)
            assert st & IN_POS and st & READY and not st & MOVE
            assert abs(clock(m) - t0 - total) <= 0.001
            assert m.read32(ARM, FEEDBACK, signed=True) == 6000
            move(m, ARM, 0)
        finally:
            m.close()


def test_homing(rtu):
    move(rtu, SAMPLE, 5.0)
    assert not rtu.read32(SAMPLE, STATUS) & HOME_END
    rtu.write32(SAMPLE, INPUT, [ZHOME])
    rtu.write32(SAMPLE, INPUT, [0])
    st = wait_status(rtu, SAMPLE, HOME_END)
    assert st & IN_POS and st & READY
    assert rtu.read32(SAMPLE, FEEDBACK, signed=True) == 0
    move(rtu, SAMPLE, 1.0)  # a new move ends the home state
    assert not rtu.read32(SAMPLE, STATUS) & HOME_END
    move(rtu, SAMPLE, 0)


def test_stop_holds_position():
    """STOP halts the azimuth where it is, and it stays there. On a
    gonio-sim of its own on the simulated clock, so that where the STOP
    lands is the rig's doing: the move runs for exactly the second of rig
    time the wait register passes (docs/gonio-sim.md, "The simulated
    clock"), whatever the host spends. At 30 deg/s and 60 deg/s^2 that is
    7.5 deg of acceleration and 15 deg of cruise: 22.5 deg. On the wall
    clock a host that held the test for the move's 6 s of rig time (0.12 s
    of wall time at the time scale) let it arrive."""
    pytest.importorskip("serial")
    with gonio_sim("--clock", "simulated") as s:
        m = RtuMaster(s["pty"])
        try:
            start(m, AZIMUTH, 170, 30, 60)  # about 6 s of rig time
            m.write32(DETECTOR, WAIT, [1_000_000])  # 1 s of rig time
            m.write32(AZIMUTH, INPUT, [STOP])
            m.write32(AZIMUTH, INPUT, [0])
            here = m.read32(AZIMUTH, FEEDBACK, signed=True)
            assert here == 2250
            m.write32(DETECTOR, WAIT, [1_000_000])  # moving, it would be at 52.5 deg
            st = m.read32(AZIMUTH, STATUS)
            assert not st & MOVE and not st & IN_POS and st & READY
            assert m.read32(AZIMUTH, FEEDBACK, signed=True) == here
            move(m, AZIMUTH, 0)
        finally:
            m.close()


def test_soft_limit_alarm_and_reset(rtu):
    move(rtu, SAMPLE, 0)
    start(rtu, SAMPLE, 100.0, 20, 40)  # beyond the rig's +90
    st = rtu.read32(SAMPLE, STATUS)
    assert st & ALM_A and not st & READY
    assert rtu.read32(SAMPLE, ALARM) == 0x66
    # In alarm a valid move is ignored, and homing too.
    start(rtu, SAMPLE, 5.0, 20, 40)
    rtu.write32(SAMPLE, INPUT, [ZHOME])
    rtu.write32(SAMPLE, INPUT, [0])
    time.sleep(2.0 / TIME_SCALE)
    assert rtu.read32(SAMPLE, FEEDBACK, signed=True) == 0
    assert rtu.read32(SAMPLE, ALARM) == 0x66
    rtu.write32(SAMPLE, INPUT, [ALM_RST])
    rtu.write32(SAMPLE, INPUT, [0])
    st = rtu.read32(SAMPLE, STATUS)
    assert not st & ALM_A and st & READY
    assert rtu.read32(SAMPLE, ALARM) == 0
    move(rtu, SAMPLE, 5.0)
    move(rtu, SAMPLE, 0)


def test_detector_cycle(rtu):
    """BUSY for the integration time on the rig clock, then READY with the
    sequence one higher."""
    seq0 = rtu.read32(DETECTOR, 0x08)
    t1 = clock(rtu)
    rtu.write32(DETECTOR, 0x00, [500000, 1])  # 0.5 s
    t2 = clock(rtu)
    while True:
        c1 = clock(rtu)
        st = rtu.read32(DETECTOR, 0x04)
        c2 = clock(rtu)
        if st & 0x2:
            assert not st & 0x1
            assert c2 - t1 >= 0.5 - 0.002
            break
        assert st & 0x1
        assert c1 - t2 <= 0.5 + 0.002
        assert c1 - t1 < 5, "integration never ended"
    assert rtu.read32(DETECTOR, 0x08) == seq0 + 1


def test_survives_random_input(sim, rtu):
    """Noise, truncated frames and well-formed frames with random contents
    (valid CRC, any function, address and count): gonio-sim answers what it
    answers and keeps running, and a normal request still gets its reply."""
    import random
    rnd = random.Random(20261122)
    for i in range(400):
        n = rnd.randint(1, 40)
        body = bytes([rnd.choice([1, 2, 3, 4, 0, 9, 247])]) + bytes(rnd.getrandbits(8)
                                                                      for _ in range(n))
        data = frame(body) if i % 2 else body
        rtu.raw(data, timeout=0.002)
    time.sleep(0.3)  # a silence ends whatever was left half-framed; late replies land
    rtu.port.reset_input_buffer()
    assert sim["proc"].poll() is None
    assert rtu.read32(DETECTOR, 0x06) == 3
