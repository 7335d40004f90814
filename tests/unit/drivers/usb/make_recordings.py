#!/usr/bin/python3
"""Write the USB2000+ traffic the driver tests replay (tests/unit/drivers/usb).

There is no spectrometer on the build machines, so the recordings are
written here in the format umockdev-record produces for usbdevfs
(USBDEVFS_REAPURBNDELAY lines: type endpoint status flags buffer_length
actual_length error_count data-hex; an IN reply indented one space deeper
than the request it answers). docs/usb-spectrometer.md says how to record a
real device instead. Run from this folder; the output is committed.
"""
import math
import struct

DEV = "/dev/bus/usb/001/005"
COEF = ["339.620361", "0.3805263", "-1.953270E-05", "-1.18845E-09"]
# The factory's nonlinearity correction: slot 14 the order, slots 6.. the
# coefficients of P in y / P(y) (y: counts above the electric dark). Like a
# real USB2000+'s: P a few % under 1 at low counts, rising toward 1.
NL = ["0.95", "1.2E-06", "-4.0E-12"]
INTEGRATION_US = 100000
PIXELS = 2048
DARK = (6, 21)  # electric dark pixels, half-open


def counts():
    """A halogen-lit white tile seen through the grating: a dark offset of
    about 1500, a smooth lamp curve and a fixed ripple standing in for noise."""
    c = [float(x) for x in COEF]
    sig_peak = max(shape(c, p) for p in range(PIXELS))
    out = []
    for p in range(PIXELS):
        dark = 1500 + 7 * math.sin(0.37 * p)
        sig = 0.0 if p < DARK[1] else 42000 * shape(c, p) / sig_peak
        out.append(int(round(min(dark + sig, 65535))))
    return out


def shape(c, p):
    """Planck-like 3000 K lamp curve times a silicon response falling off at
    both ends, with a 2 % ripple."""
    lam = c[0] + p * (c[1] + p * (c[2] + p * c[3]))
    lamp = (lam / 600.0) ** -5 / (math.exp(14388e3 / (lam * 3000.0)) - 1)
    resp = math.exp(-((lam - 620.0) / 260.0) ** 2)
    return lamp * resp * (1 + 0.02 * math.sin(0.9 * p))


def urb(ep, data, depth=0, length=None, status=0):
    """One reaped bulk URB; data is what was sent (OUT) or received (IN)."""
    if length is None:
        length = len(data)
    return "%sUSBDEVFS_REAPURBNDELAY 0 3 %d %d 0 %d %d 0 %s" % (
        " " * depth, ep, status, length, len(data), data.hex().upper())


def info_reply(slot, text):
    body = text.encode("ascii")[:14]
    return bytes([0x05, slot]) + body + bytes(15 - len(body))


def status_reply(integration_us):
    return (struct.pack("<HI", PIXELS, integration_us) + bytes([0, 0, 0, 9, 1, 0, 0, 0, 0x80, 0]))


def opening(lines, nl=None):
    lines.append(urb(0x01, b"\x01"))                       # initialise
    for slot, text in enumerate(COEF, start=1):            # wavelength calibration
        lines.append(urb(0x01, bytes([0x05, slot])))
        lines.append(urb(0x81, info_reply(slot, text), depth=1))
    nl = nl or NL
    query(lines, 14, str(len(nl) - 1))                     # nonlinearity order
    for slot, text in enumerate(nl, start=6):              # its coefficients
        query(lines, slot, text)
    lines.append(urb(0x01, b"\xfe"))                       # status
    lines.append(urb(0x81, status_reply(2000), depth=1))


def query(lines, slot, text):
    lines.append(urb(0x01, bytes([0x05, slot])))
    lines.append(urb(0x81, info_reply(slot, text), depth=1))


def spectrum(lines, raw, packets=None, sync=b"\x69", status_at=None, integration=True):
    """Integration (unless integration is False: the driver sends it only
    when it changes), status, request, 8 packets and the sync byte.
    packets: override the packet list; status_at: (index, errno) ends that
    packet with a kernel URB status instead (e.g. -108 ESHUTDOWN when
    unplugged)."""
    if integration:
        lines.append(urb(0x01, b"\x02" + struct.pack("<I", INTEGRATION_US)))
    lines.append(urb(0x01, b"\xfe"))
    lines.append(urb(0x81, status_reply(INTEGRATION_US), depth=1))
    lines.append(urb(0x01, b"\x09"))
    pk = packets if packets is not None else [raw[i:i + 512] for i in range(0, len(raw), 512)]
    depth = 1
    for i, data in enumerate(pk):
        if status_at and status_at[0] == i:
            lines.append(urb(0x82, b"", depth=depth, length=512, status=status_at[1]))
            return
        lines.append(urb(0x82, data, depth=depth, length=512))
        depth += 1
    if sync is not None:
        lines.append(urb(0x82, sync, depth=depth, length=512))


def write(name, lines):
    with open(name, "w") as f:
        f.write("@DEV %s\n" % DEV)
        f.write("\n".join(lines) + "\n")


def main():
    raw = b"".join(struct.pack("<H", v) for v in counts())
    lines = []
    opening(lines)
    spectrum(lines, raw)
    write("spectrum.ioctl", lines)

    lines = []
    opening(lines)
    pk = [raw[i:i + 512] for i in range(0, len(raw), 512)]
    pk[2] = pk[2][:100]                                    # packet 3 ends early
    spectrum(lines, raw, packets=pk[:3])
    write("short_read.ioctl", lines)

    lines = []
    opening(lines)
    spectrum(lines, raw, sync=b"\x00")                     # sync byte replaced
    write("bad_sync.ioctl", lines)

    lines = []
    opening(lines)
    spectrum(lines, raw, status_at=(3, -108))              # unplugged during packet 4
    write("unplug.ioctl", lines)

    lines = []
    opening(lines)
    sat = counts()
    sat[700] = 65535                                       # one pixel at full scale (~580 nm)
    spectrum(lines, b"".join(struct.pack("<H", v) for v in sat))
    write("saturated.ioctl", lines)

    lines = [urb(0x01, b"\x01"), urb(0x01, b"\x05\x01"),
             urb(0x81, info_reply(1, COEF[0]), depth=1), urb(0x01, b"\x05\x02"),
             urb(0x81, info_reply(2, "0.38O5263"), depth=1)]   # a letter O in slot 2
    write("bad_calibration.ioctl", lines)

    lines = []
    opening(lines, nl=["0.95", "-2.0E-05"])                # P(y) < 0 from 47500 counts
    write("bad_nonlinearity.ioctl", lines)


if __name__ == "__main__":
    main()
