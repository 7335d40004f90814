"""goniod survives a dropped Modbus TCP connection: gonio-sim closes every
TCP connection on SIGUSR1 (as a restarted gateway or a network drop
would), twice during a DS3 capture; the drivers re-open the connection
within the request's retries and the capture completes with every point
exactly once; the stop document counts the re-opened connections."""
import os
import signal

from conftest import gonio_sim, tg

SCALE = 100


def journal_rows(path):
    """Point indices of samples.csv, one per record, in order."""
    with open(path) as f:
        return [int(line.split(",", 1)[0]) for line in f.read().splitlines()[1:]]


def test_capture_survives_tcp_drops():
    with gonio_sim("--scene", "ideal", "--time-scale", str(SCALE)) as sim:
        d = tg.Daemon(sim["folder"], driver="  kind: modbus-tcp\n  host: 127.0.0.1\n  port: %d\n"
                      "  time_scale: %d\n  timeout_s: %g\n  slaves: {sample: 1, arm: 2, "
                      "detector: 3, azimuth: 4}\n" % (sim["port"], SCALE, 0.5 * tg.SLOW))
        try:
            d.start()
            c = d.connect()
            c.request("watch")
            assert c.request("capture", plan="ds3", name="drop")["class"] == "OK"
            events = drops = 0
            docs = []
            while True:
                doc = c.read()
                assert doc is not None, docs[-3:]
                docs.append(doc)
                if doc.get("class") == "stop":
                    break
                if doc.get("class") == "event":
                    events += 1
                    if events in (1, 26):  # after the first point, and half way
                        sim["proc"].send_signal(signal.SIGUSR1)
                        drops += 1
            stop = docs[-1]
            assert drops == 2, "the capture ended before both drops: %r" % stop
            assert stop["reason"] == "complete", stop
            assert stop["samples"] == 52
            assert stop["comm"]["failed"] == 0 and stop["comm"]["retries"] >= 2, stop["comm"]
            # Each drop is noticed by the next request, which re-opens the
            # connection at least once.
            assert stop["comm"]["reconnects"] >= 2, stop["comm"]
            # (in the pre-scan's order first, docs/plans.md: the order is not the point here)
            assert sorted(journal_rows(os.path.join(d.root, "drop", "samples.csv"))) == \
                list(range(52))
        finally:
            d.stop()
