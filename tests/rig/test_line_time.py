"""gonio-sim --baud and --tcp-latency charge the bus's time in rig time:
between two consecutive reads of the rig clock the clock advances by at
least what the frames in between cost on the line (the first reply and the
second request, each with its t3.5 silence), and over TCP by at least the
latency. Lower bounds only: a wait never ends early, but a loaded machine
may make it longer, and no test asserts how long anything takes."""
import socket
import struct

import pytest

from conftest import RtuMaster, gonio_sim

BAUD, SCALE, LATENCY_MS = 1200, 10, 200
CLOCK = 0x0A
DETECTOR = 3


@pytest.fixture(scope="module")
def slow_sim():
    pytest.importorskip("serial")
    with gonio_sim("--time-scale", str(SCALE), "--baud", str(BAUD), "--tcp-latency",
                   str(LATENCY_MS)) as s:
        yield s


def frame_s(n):
    """A frame of n bytes at BAUD (11-bit characters) with its t3.5 silence."""
    return (n + 3.5) * 11.0 / BAUD


def test_rtu_exchanges_take_their_line_time(slow_sim):
    m = RtuMaster(slow_sim["pty"], BAUD)
    try:
        clocks = [m.read32(DETECTOR, CLOCK) / 1000.0 for _ in range(4)]
    finally:
        m.close()
    # Reply of a 2-register read: 9 bytes; request: 8 bytes.
    least = frame_s(9) + frame_s(8) - 0.002  # the clock register counts ms
    for a, b in zip(clocks, clocks[1:]):
        assert b - a >= least, (clocks, least)


def test_tcp_replies_take_the_latency(slow_sim):
    s = socket.create_connection(("127.0.0.1", slow_sim["port"]), timeout=5)
    clocks = []
    try:
        for tid in range(1, 4):
            s.sendall(struct.pack(">HHHBBHH", tid, 0, 6, DETECTOR, 0x03, CLOCK, 2))
            reply = b""
            while len(reply) < 13:
                chunk = s.recv(13 - len(reply))
                assert chunk, "connection closed"
                reply += chunk
            clocks.append(struct.unpack(">I", reply[9:13])[0] / 1000.0)
    finally:
        s.close()
    for a, b in zip(clocks, clocks[1:]):
        assert b - a >= LATENCY_MS / 1000.0 - 0.002, clocks
