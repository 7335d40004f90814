"""Fault injection between goniod's Modbus RTU driver and gonio-sim.

A man in the middle written here with pyserial and os.openpty(): goniod opens
the slave side of a pty pair this test creates; a thread frames each request
(RTU length per function code), forwards it to gonio-sim's pty over pyserial,
frames the reply and hands it back, possibly altered. Transient faults (a
dropped reply, garbage, a bad CRC, a late reply) must be retried with a capture
identical to a fault-free one; a drive alarm or a stall (status rewritten in
the replies) must fail the capture naming the cause, with the daemon still up
and the samples journalled so far kept."""
import os
import select
import shutil
import subprocess
import sys
import threading
import time
import tty

import pytest

from conftest import crc16, frame, reply_length

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "daemon"))
import goniod_harness as tg  # noqa: E402  (Daemon, Conn)

BIN = os.environ.get("GONIO_BIN", "build/bin")
SIM = os.path.join(BIN, "gonio-sim")
SCALE = 1000
# goniod's response timeout and the quiet window it drains after a failed
# attempt: long enough that a loaded host's ordinary answer through the
# injector's thread is not taken for a fault (doubled under valgrind,
# tg.VALGRIND, where goniod and gonio-sim run on memcheck), so that only the
# injected faults time out.
TIMEOUT_S = 0.5 * (2 if tg.VALGRIND else 1)
DRAIN_S = 2 * TIMEOUT_S
PLAN = "ds3"
STATUS, ALARM = 0x7E, 0x80
ALM_A, MOVE, IN_POS = 1 << 7, 1 << 13, 1 << 14


def request_length(buf: bytes):
    """Length of the RTU request starting buf, or None while unknown."""
    if len(buf) < 2:
        return None
    if buf[1] in (0x0F, 0x10):
        return None if len(buf) < 7 else 9 + buf[6]
    return 8


def set_register(reply: bytes, req: bytes, reg: int, fn):
    """reply with holding register reg (if the read covers it) replaced by
    fn(old), CRC recomputed."""
    if reply[1] != 0x03:
        return reply
    start, count = (req[2] << 8) | req[3], (req[4] << 8) | req[5]
    if not start <= reg < start + count:
        return reply
    body = bytearray(reply[:-2])
    i = 3 + 2 * (reg - start)
    new = fn((body[i] << 8) | body[i + 1]) & 0xFFFF
    body[i], body[i + 1] = new >> 8, new & 0xFF
    return frame(bytes(body))


class Injector:
    """Forwards frames between a pty pair of its own and gonio-sim's pty.
    fault(n, req, reply) -> list of (delay_s, bytes) to send back instead of
    [(0, reply)], or None to pass the reply through."""

    def __init__(self, sim_pty, fault=None):
        import serial
        self.sim = serial.Serial(sim_pty, 115200, timeout=0)
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)
        self.path = os.ttyname(self.slave)
        self.fault = fault
        self.n = 0
        self.injected = 0
        self.running = True
        self.thread = threading.Thread(target=self.loop, daemon=True)
        self.thread.start()

    def close(self):
        self.running = False
        self.thread.join(timeout=5)
        self.sim.close()
        os.close(self.master)
        os.close(self.slave)

    def read_request(self):
        buf = b""
        while self.running:
            r, _, _ = select.select([self.master], [], [], 0.05)
            if not r:
                if buf:  # 3.5 characters of silence ended a short frame
                    return buf
                continue
            buf += os.read(self.master, 256)
            need = request_length(buf)
            if need is not None and len(buf) >= need:
                return buf[:need]
        return None

    def exchange(self, req):
        self.sim.reset_input_buffer()
        self.sim.write(req)
        buf = b""
        deadline = time.monotonic() + 10 * TIMEOUT_S
        while time.monotonic() < deadline:
            n = self.sim.in_waiting
            if n:
                buf += self.sim.read(n)
                need = reply_length(buf)
                if need is not None and len(buf) >= need:
                    return buf[:need]
            else:
                time.sleep(0.0002)
        return None

    def loop(self):
        while self.running:
            req = self.read_request()
            if req is None:
                break
            reply = self.exchange(req)
            if reply is None:
                continue
            self.n += 1
            out = self.fault(self.n, req, reply) if self.fault else None
            if out is None:
                out = [(0, reply)]
            else:
                self.injected += 1
            for delay, data in out:
                if delay:
                    time.sleep(delay)
                if data:
                    os.write(self.master, data)


@pytest.fixture
def rig():
    if not os.path.exists(SIM):
        pytest.skip("gonio-sim not built")
    folder = tg.tmpdir()
    out = os.path.join(folder, "sim.out")
    sim = subprocess.Popen(tg.wrap([SIM, "--scene", "ideal", "--time-scale", str(SCALE)], folder),
                           stdout=open(out, "w"), stderr=subprocess.DEVNULL,
                           preexec_fn=tg.child_procs.die_with_parent)
    deadline = time.time() + tg.START_S
    text = ""
    while time.time() < deadline and "\n" not in text:
        time.sleep(0.02)
        text = open(out).read()
    state = {"folder": folder, "pty": text.split("\n")[0], "objs": []}
    yield state
    try:
        for o in state["objs"]:
            o.close() if isinstance(o, Injector) else o.stop()
        sim.terminate()
        rc = sim.wait(timeout=2 * tg.START_S)
        tg.assert_valgrind_clean(folder)
        assert rc == 0, "gonio-sim exited %d on SIGTERM" % rc
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def capture(rig, name, fault=None):
    """goniod (modbus-rtu.yaml's driver keys, on the injector's pty) runs
    PLAN; returns (stop document, injector, daemon)."""
    inj = Injector(rig["pty"], fault)
    rig["objs"].append(inj)
    with open(os.path.join(tg.SOURCE, "configs", "goniod", "modbus-rtu.yaml")) as f:
        shipped = f.read()
    driver = shipped.split("driver:\n", 1)[1].split("capture_root")[0]
    driver = (driver.replace("/dev/ttyUSB0", inj.path)
              .replace("time_scale: 1 ", "time_scale: %d " % SCALE)
              .replace("timeout_s: 0.5", "timeout_s: %g\n  drain_s: %g" % (TIMEOUT_S, DRAIN_S))
              .replace("retries: 4", "retries: 2"))  # three faults in a row outlast them
    assert inj.path in driver and "timeout_s: %g" % TIMEOUT_S in driver, driver
    assert "retries: 2" in driver, driver
    folder = os.path.join(rig["folder"], name)
    os.mkdir(folder)
    d = tg.Daemon(folder, driver=driver).start()
    rig["objs"].insert(0, d)
    c = d.connect()
    c.request("watch")
    assert c.request("capture", plan=PLAN, name=name)["class"] == "OK"
    stop = c.until_stop(name)[-1]
    return stop, inj, d


def samples(d, name):
    """The rgb triples by geometry (theta_i, theta_r to 0.01 deg): each capture
    orders its travel from where the previous one left the axes, so the
    same geometry can carry a different point number."""
    with open(os.path.join(d.root, name, "samples.csv")) as f:
        rows = [line.split(",") for line in f.read().splitlines()[1:]]
    return {(round(float(r[1]), 2), round(float(r[2]), 2)): [float(v) for v in r[8:11]]
            for r in rows}


def nth(match, k, make, times=1):
    """A fault on the k-th request matching (slave, function, address) and
    the times-1 exchanges after it. The targets are requests whose failure
    fails the capture when the retries run out (checked with times=3); a
    failed read of the detector's clock, for one, does not."""
    seen = [0, None]

    def fault(n, req, reply):
        if seen[1] is None and (req[0], req[1], (req[2] << 8) | req[3]) == match:
            seen[0] += 1
            if seen[0] == k:
                seen[1] = n
        if seen[1] is not None and seen[1] <= n < seen[1] + times:
            return make(req, reply)
        return None
    return fault


def drop(req, reply):
    return [(0, b"")]


def garbage(req, reply):
    return [(0, bytes([0xA5, 0x00, 0xFF, 0x13, 0x37, 0x5A, 0xC3]))]


def bad_crc(req, reply):
    return [(0, reply[:-1] + bytes([reply[-1] ^ 0x55]))]


def late(req, reply):
    # Past the first attempt's deadline, in the middle of the drain after
    # it: a whole timeout from either end of the window, so a held host moves
    # it neither onto the deadline nor past the drain into the retry.
    return [(TIMEOUT_S + DRAIN_S / 2, reply)]


@pytest.fixture(scope="module")
def reference():
    """A fault-free capture's samples (run once per module)."""
    return {}


def clean(rig, reference):
    if "ref" not in reference:
        stop, _, d = capture(rig, "clean")
        assert stop["reason"] == "complete", stop
        reference["ref"] = samples(d, "clean")
    return reference["ref"]


# Each fault on a different exchange: the arm's move command (a write whose
# repetition restarts the same move; after the first leg it writes the block
# from the position, 0x5C, the drive holding the rest), status and position
# reads. The arm moves at every DS3 point; the sample, whose target repeats,
# only at 9 (a move to where an axis rests sends nothing), too few for a 10th
# status read.
TRANSIENT = [(drop, (2, 0x10, 0x5C)), (garbage, (2, 0x03, STATUS)),
             (bad_crc, (2, 0x03, 0xCC)), (late, (2, 0x03, STATUS))]


@pytest.mark.parametrize("kind,match", TRANSIENT, ids=[k.__name__ for k, _ in TRANSIENT])
def test_transient_fault_is_retried(rig, reference, kind, match):
    want = clean(rig, reference)
    stop, inj, d = capture(rig, "t", nth(match, 10, kind))
    assert inj.injected == 1
    assert stop["reason"] == "complete", stop
    got = samples(d, "t")
    assert sorted(got) == sorted(want)
    for p in want:
        assert got[p] == want[p], (p, got[p], want[p])


@pytest.mark.parametrize("kind,match", TRANSIENT, ids=[k.__name__ for k, _ in TRANSIENT])
def test_fault_beyond_retries_fails(rig, kind, match):
    """The same fault three times in a row outlasts the driver's two
    retries: the capture fails naming the attempts. (A held reply also
    holds up the other axes' requests behind it, so the axis named may be
    another one than the target's.)"""
    stop, inj, d = capture(rig, "t", nth(match, 10, kind, times=3))
    assert inj.injected == 3
    assert stop["exit_status"] == "fail", stop
    assert "(3 attempts)" in stop["message"], stop
    assert d.alive()


def after(at, rewrite):
    """From the at-th exchange on, status/alarm reads of the sample axis
    (slave 1) are rewritten."""
    def fault(n, req, reply):
        if n < at or req[0] != 1 or req[1] != 0x03:
            return None
        new = rewrite(req, reply)
        return None if new == reply else [(0, new)]
    return fault


def alarm(req, reply):
    r = set_register(reply, req, STATUS + 1, lambda v: v | ALM_A)
    return set_register(r, req, ALARM + 1, lambda v: 0x30)


def stall(req, reply):
    return set_register(reply, req, STATUS + 1, lambda v: (v | MOVE) & ~IN_POS)


@pytest.mark.parametrize("kind,needle", [(alarm, "0x30"), (stall, "stall")],
                         ids=["alarm", "stall"])
def test_persistent_fault_fails_point(rig, kind, needle):
    stop, inj, d = capture(rig, "p", after(200, kind))
    assert inj.injected > 0
    assert stop["exit_status"] == "fail", stop
    assert needle in stop["message"], stop
    assert d.alive()
    assert d.connect().request("status")["state"] == "idle"
    got = samples(d, "p")
    assert 0 < len(got) < tg.plan_total(os.path.join(d.root, "p"))
