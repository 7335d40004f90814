"""gonio-sim over Modbus TCP with pymodbus as the master, cross-checked
against the hand-built RTU master on the same bus: the same registers,
the same float32 packing (upper word first), the same exceptions."""
import struct
import time

import pytest

from conftest import TIME_SCALE

pymodbus_client = pytest.importorskip("pymodbus.client")

SAMPLE, ARM, DETECTOR = 1, 2, 3


def regs(client, slave, addr, count):
    rr = client.read_holding_registers(addr, count, slave=slave)
    assert not rr.isError(), rr
    return list(rr.registers)


def test_same_registers_on_both_transports(tcp, rtu):
    # Write the direct-data block over TCP (without the trigger), read it over RTU.
    block = [0, 0, 0, 1, 0, 1234, 0, 2000, 0, 4000, 0, 4000, 0, 1000, 0, 0]
    wr = tcp.write_registers(0x58, block, slave=ARM)
    assert not wr.isError(), wr
    assert rtu.read(ARM, 0x58, 16) == block
    # Negative positions are two's complement, upper word first.
    neg = (-1234) & 0xFFFFFFFF
    rtu.write(ARM, 0x5C, [neg >> 16, neg & 0xFFFF])
    assert regs(tcp, ARM, 0x5C, 2) == [0xFFFF, 0xFB2E]
    # Trigger over TCP; the move shows on RTU.
    wr = tcp.write_register(0x67, 1, slave=ARM)
    assert not wr.isError(), wr
    deadline = time.monotonic() + 2
    while rtu.read32(ARM, 0xCC, signed=True) != -1234 and time.monotonic() < deadline:
        time.sleep(0.002)
    assert rtu.read32(ARM, 0xCC, signed=True) == -1234
    fb = regs(tcp, ARM, 0xCC, 2)
    assert struct.unpack(">i", struct.pack(">HH", *fb))[0] == -1234
    rtu.write(ARM, 0x58, [0, 0, 0, 1, 0, 0, 0, 2000, 0, 4000, 0, 4000, 0, 1000, 0, 1])
    time.sleep(3.0 / TIME_SCALE)


def test_float_packing(tcp, rtu):
    """A reading's channels decode to the same binary32 values through
    pymodbus's decoder (big-endian words and bytes) and by hand."""
    from pymodbus.constants import Endian
    from pymodbus.payload import BinaryPayloadDecoder
    rtu.write32(DETECTOR, 0x00, [1000, 1])
    time.sleep(0.01)
    while not rtu.read32(DETECTOR, 0x04) & 0x2:
        time.sleep(0.001)
    raw_rtu = rtu.read(DETECTOR, 0x0C, 6)
    raw_tcp = regs(tcp, DETECTOR, 0x0C, 6)
    assert raw_rtu == raw_tcp
    dec = BinaryPayloadDecoder.fromRegisters(raw_tcp, byteorder=Endian.Big, wordorder=Endian.Big)
    by_pymodbus = [dec.decode_32bit_float() for _ in range(3)]
    by_hand = list(struct.unpack(">3f", struct.pack(">6H", *raw_rtu)))
    assert by_pymodbus == by_hand
    assert all(0 < v < 1e6 for v in by_hand)


def test_exceptions_over_tcp(tcp):
    rr = tcp.read_holding_registers(0x0000, 1, slave=SAMPLE)
    assert rr.isError() and rr.exception_code == 2
    rr = tcp.write_register(0x7E, 1, slave=SAMPLE)
    assert rr.isError() and rr.exception_code == 2
    rr = tcp.read_input_registers(0x7E, 2, slave=SAMPLE)
    assert rr.isError() and rr.exception_code == 1


def test_survives_random_tcp_input(sim):
    """Random MBAP frames and garbage on raw sockets: the server drops the
    bad connections and keeps serving the others."""
    import random
    import socket
    rnd = random.Random(7)
    for i in range(100):
        s = socket.create_connection(("127.0.0.1", sim["port"]), timeout=1)
        n = rnd.randint(1, 30)
        payload = bytes(rnd.getrandbits(8) for _ in range(n))
        if i % 2:  # a plausible header around a random PDU
            payload = struct.pack(">HHHB", i, 0, n + 1, rnd.choice([1, 2, 3, 4, 9])) + payload
        s.sendall(payload)
        s.settimeout(0.01)
        try:
            s.recv(300)
        except (socket.timeout, ConnectionError):
            pass
        s.close()
    assert sim["proc"].poll() is None
    client = pymodbus_client.ModbusTcpClient("127.0.0.1", port=sim["port"], timeout=1)
    assert client.connect()
    assert regs(client, DETECTOR, 0x06, 2) == [0, 3]
    client.close()
