"""gonio-sim answers as a Modbus device must (Modbus Application Protocol
V1.1b3; Modbus Messaging on TCP/IP Implementation Guide V1.0b), checked with
pymodbus as an independent master and, where pymodbus cannot produce the
malformed request, with raw frames built here from the specifications:

- an exception answer carries the request's function code with its top bit
  set, for any unsupported code, 0x80 included (it came back as 0x00);
- a Modbus TCP frame whose protocol identifier is not 0 is not served, and
  the connection goes on serving (it was answered);
- an FC 0x10 whose byte count disagrees with its quantity or with the MBAP
  length gets exception 03 on the same connection (it was closed);
- a write of 124 registers (more than 123) gets exception 03, over TCP and
  RTU (it got no answer)."""
import socket
import struct

import pytest

from conftest import frame

pymodbus_client = pytest.importorskip("pymodbus.client")

SAMPLE, DETECTOR = 1, 3
DIRECT, STATUS = 0x58, 0x7E


class RawTcp:
    """One Modbus TCP connection, frames built by hand (MBAP: transaction,
    protocol, length of what follows, unit id)."""

    def __init__(self, port):
        self.s = socket.create_connection(("127.0.0.1", port), timeout=2)
        self.tid = 0

    def close(self):
        self.s.close()

    def send(self, unit, pdu, protocol=0, length=None):
        self.tid += 1
        n = len(pdu) + 1 if length is None else length
        self.s.sendall(struct.pack(">HHHB", self.tid, protocol, n, unit) + pdu)
        return self.tid

    def recv(self, timeout=2.0):
        """The next reply (tid, unit, pdu), or None after timeout."""
        self.s.settimeout(timeout)
        try:
            head = self._exactly(7)
        except socket.timeout:
            return None
        tid, proto, n, unit = struct.unpack(">HHHB", head)
        assert proto == 0, head.hex()
        return tid, unit, self._exactly(n - 1)

    def _exactly(self, n):
        buf = b""
        while len(buf) < n:
            chunk = self.s.recv(n - len(buf))
            assert chunk, "connection closed by gonio-sim"
            buf += chunk
        return buf

    def exchange(self, unit, pdu):
        tid = self.send(unit, pdu)
        reply = self.recv()
        assert reply is not None and reply[0] == tid and reply[1] == unit, reply
        return reply[2]


@pytest.fixture
def raw(sim):
    c = RawTcp(sim["port"])
    yield c
    c.close()


def read_status_pdu():
    return bytes([0x03, 0, STATUS, 0, 2])


@pytest.mark.parametrize("code", [0x80, 0x81, 0xFF, 0x07, 0x2B])
def test_unsupported_function_gets_exception_01(raw, rtu, code):
    assert raw.exchange(SAMPLE, bytes([code])) == bytes([code | 0x80, 0x01])
    reply = rtu.request(SAMPLE, bytes([code, 0, 0]))
    assert reply == bytes([code | 0x80, 0x01]), reply


def test_foreign_protocol_id_is_not_served(raw):
    """By hand: pymodbus 3.0 itself ignores a reply whose protocol id is not
    its request's, so it cannot tell whether the server answered. A read
    with protocol id 0x1234 then a normal one on the same connection: only
    the normal one is answered, so the stream stayed in step."""
    raw.send(SAMPLE, read_status_pdu(), protocol=0x1234)
    assert raw.recv(timeout=0.3) is None
    pdu = raw.exchange(SAMPLE, read_status_pdu())
    assert pdu[:2] == bytes([0x03, 4])


def test_write_byte_count_mismatch_gets_exception_03(raw):
    # Quantity 2 with a byte count of 3 (and 3 bytes of data).
    pdu = bytes([0x10, 0, DIRECT, 0, 2, 3, 0, 0, 0])
    assert raw.exchange(SAMPLE, pdu) == bytes([0x90, 0x03])
    # Byte count 4 as the quantity asks, but the MBAP length carries 2.
    pdu = bytes([0x10, 0, DIRECT, 0, 2, 4, 0, 0])
    assert raw.exchange(SAMPLE, pdu) == bytes([0x90, 0x03])
    # Byte count 4, and 6 bytes of data behind it.
    pdu = bytes([0x10, 0, DIRECT, 0, 2, 4]) + bytes(6)
    assert raw.exchange(SAMPLE, pdu) == bytes([0x90, 0x03])
    # The connection serves on.
    assert raw.exchange(DETECTOR, bytes([0x03, 0, 0x06, 0, 2])) == bytes([0x03, 4, 0, 0, 0, 3])


def test_write_of_124_registers_gets_exception_03(sim, tcp, rtu):
    rr = tcp.write_registers(DIRECT, [0] * 124, slave=SAMPLE)
    assert rr.isError() and rr.exception_code == 3, rr
    rr = tcp.write_registers(DIRECT, [0] * 123, slave=SAMPLE)  # fits, but runs off the map
    assert rr.isError() and rr.exception_code == 2, rr
    rtu.close()  # one master on the pty at a time
    from pymodbus.framer.rtu_framer import ModbusRtuFramer
    serial = pymodbus_client.ModbusSerialClient(port=sim["pty"], framer=ModbusRtuFramer,
                                                baudrate=115200, timeout=1)
    assert serial.connect()
    try:
        rr = serial.write_registers(DIRECT, [0] * 124, slave=SAMPLE)
        assert rr.isError() and rr.exception_code == 3, rr
        rr = serial.read_holding_registers(0x06, 2, slave=DETECTOR)
        assert not rr.isError() and list(rr.registers) == [0, 3], rr
    finally:
        serial.close()


def test_rtu_frame_of_124_registers_by_hand(rtu):
    """The same over RTU by hand: 257 bytes, over the 256 of an RTU ADU, yet
    answered with the exception rather than lost."""
    body = bytes([SAMPLE, 0x10, 0, DIRECT, 0, 124, 248]) + bytes(248)
    reply = rtu.raw(frame(body))
    assert reply is not None and reply[1:3] == bytes([0x90, 0x03]), reply
