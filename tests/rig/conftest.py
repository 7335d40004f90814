"""Fixtures of the rig tests: a gonio-sim process (ideal scene, default rig,
100 steps/deg) on its pty and on TCP, and a Modbus RTU master written here
from the specification (frames and CRC-16 by hand), independent of the C
drivers and of libmodbus."""
import contextlib
import os
import shutil
import signal
import subprocess
import sys
import time

import pytest

# goniod's test helpers: under make check-valgrind (GONIO_WRAP) gonio-sim
# runs on memcheck too, and its report fails the test that started it.
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "daemon"))
import goniod_harness as tg  # noqa: E402

TIME_SCALE = 50.0


def crc16(data: bytes) -> int:
    """Modbus CRC-16: polynomial 0xA001 (reflected 0x8005), initial 0xFFFF."""
    crc = 0xFFFF
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = (crc >> 1) ^ 0xA001 if crc & 1 else crc >> 1
    return crc


def frame(body: bytes) -> bytes:
    """An RTU frame: the body, then its CRC low byte first."""
    crc = crc16(body)
    return bytes(body) + bytes([crc & 0xFF, crc >> 8])


def reply_length(buf: bytes):
    """Length of the RTU reply starting buf, or None while unknown."""
    if len(buf) < 2:
        return None
    if buf[1] & 0x80:
        return 5
    if buf[1] == 0x03:
        return None if len(buf) < 3 else 5 + buf[2]
    return 8  # 0x06, 0x10: echo of address and value/count


class RtuMaster:
    """Requests over pyserial. Replies are read by in_waiting polling: on a
    pseudo-terminal select() may report readiness with nothing to read."""

    def __init__(self, path, baud=115200):
        """baud: the line's speed, gonio-sim's --baud where it has one (a
        device at another speed does not answer)."""
        import serial
        self.port = serial.Serial(path, baud, bytesize=8, parity="N", stopbits=1, timeout=0)

    def close(self):
        self.port.close()

    def raw(self, data: bytes, timeout=2.0):
        self.port.reset_input_buffer()
        self.port.write(data)
        self.port.flush()
        buf = b""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            n = self.port.in_waiting
            if n:
                buf += self.port.read(n)
                need = reply_length(buf)
                if need is not None and len(buf) >= need:
                    return buf
            else:
                time.sleep(0.0002)
        return buf or None

    def request(self, slave, pdu: bytes, timeout=2.0):
        """Send slave+pdu; return the reply PDU (CRC checked) or None."""
        reply = self.raw(frame(bytes([slave]) + pdu), timeout)
        if reply is None:
            return None
        assert reply[0] == slave, reply.hex()
        assert crc16(reply[:-2]) == reply[-2] | (reply[-1] << 8), "bad CRC in " + reply.hex()
        return reply[1:-2]

    def read(self, slave, addr, count):
        pdu = self.request(slave, bytes([0x03, addr >> 8, addr & 0xFF, 0, count]))
        assert pdu is not None and pdu[0] == 0x03, pdu
        assert pdu[1] == 2 * count
        return [int.from_bytes(pdu[2 + 2 * i:4 + 2 * i], "big") for i in range(count)]

    def read32(self, slave, addr, signed=False):
        hi, lo = self.read(slave, addr, 2)
        v = (hi << 16) | lo
        return v - (1 << 32) if signed and v & 0x80000000 else v

    def write(self, slave, addr, values):
        body = bytes([0x10, addr >> 8, addr & 0xFF, 0, len(values), 2 * len(values)])
        body += b"".join(int(v & 0xFFFF).to_bytes(2, "big") for v in values)
        pdu = self.request(slave, body)
        assert pdu == bytes([0x10, addr >> 8, addr & 0xFF, 0, len(values)]), pdu
        return pdu

    def write32(self, slave, addr, values):
        regs = []
        for v in values:
            v &= 0xFFFFFFFF
            regs += [v >> 16, v & 0xFFFF]
        return self.write(slave, addr, regs)


def gonio_bin():
    return os.environ.get("GONIO_BIN", os.path.join(os.getcwd(), "bin"))


@contextlib.contextmanager
def gonio_sim(*args):
    """gonio-sim with args on its pty and on TCP (a free port), in a fresh
    short folder: yields {"pty", "port", "proc", "folder"}. At the end the
    process must exit 0 on SIGTERM (and, under make check-valgrind, leave a
    clean memcheck report)."""
    folder = tg.tmpdir()
    proc = subprocess.Popen(tg.wrap([os.path.join(gonio_bin(), "gonio-sim"), *args, "--tcp",
                                     "127.0.0.1:0"], folder), stdout=subprocess.PIPE, text=True,
                            preexec_fn=tg.child_procs.die_with_parent)
    try:
        pty = proc.stdout.readline().strip()
        tcp = proc.stdout.readline().strip()
        assert pty.startswith("/"), pty
        assert tcp.startswith("tcp 127.0.0.1:"), tcp
        yield {"pty": pty, "port": int(tcp.rsplit(":", 1)[1]), "proc": proc, "folder": folder}
        proc.send_signal(signal.SIGTERM)
        rc = proc.wait(timeout=2 * tg.START_S)
        tg.assert_valgrind_clean(folder)
        assert rc == 0  # a clean exit on SIGTERM
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        proc.stdout.close()
        shutil.rmtree(folder, ignore_errors=True)


@pytest.fixture(scope="module")
def sim():
    pytest.importorskip("serial")
    with gonio_sim("--time-scale", str(TIME_SCALE)) as s:
        yield s


@pytest.fixture
def rtu(sim):
    m = RtuMaster(sim["pty"])
    yield m
    m.close()


@pytest.fixture
def tcp(sim):
    """pymodbus's TCP client on gonio-sim: an independent Modbus TCP master."""
    client = pytest.importorskip("pymodbus.client").ModbusTcpClient("127.0.0.1", port=sim["port"],
                                                                    timeout=1)
    assert client.connect()
    yield client
    client.close()

