"""gonio live in a real browser: Debian's chromium driven by chromium-driver
through selenium, against a real goniod capture on the simulated rig. The
page must show one sample marker for each event goniod sent, its progress
and fit curve must change while the capture runs, a finished capture's
directory must show the same, and what is not a plain GET of / or /events
is refused with a 4xx. A screenshot of the page is kept in the build tree
(GONIO_TESTS_BIN/live-capture.png). Skipped, visibly, without chromium,
chromedriver or selenium.
"""
import http.client
import json
import os
import select
import shutil
import socket
import subprocess
import sys
import time
import unittest

sys.path.insert(0, os.path.dirname(__file__))
from goniod_harness import GONIO, START_S, TESTS_BIN, DaemonTest  # noqa: E402

import child_procs  # noqa: E402

try:
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
except ImportError:  # checked in __main__
    webdriver = None


def chromium():
    return os.environ.get("GONIO_CHROMIUM") or shutil.which("chromium") or \
        shutil.which("chromium-browser")


def chromedriver():
    return shutil.which("chromedriver") or shutil.which("chromium-driver")


def browser(folder):
    opts = webdriver.ChromeOptions()
    opts.binary_location = chromium()
    for a in ("--headless=new", "--no-sandbox", "--disable-gpu", "--no-first-run",
              "--disable-extensions", "--disable-background-networking",
              "--disable-dev-shm-usage", "--window-size=1400,900",
              "--user-data-dir=" + os.path.join(folder, "chromium-profile")):
        opts.add_argument(a)
    return webdriver.Chrome(service=Service(executable_path=chromedriver()), options=opts)


class Live:
    """A gonio live process and the URL it printed."""

    def __init__(self, *args, env=None):
        self.proc = subprocess.Popen([GONIO, "live", "--listen", "127.0.0.1:0"] + list(args),
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                     text=True, env=env, preexec_fn=child_procs.die_with_parent)
        ready, _, _ = select.select([self.proc.stdout], [], [], START_S)
        line = self.proc.stdout.readline() if ready else ""
        if not line.startswith("gonio live: http://"):
            self.stop()
            raise AssertionError("gonio live did not start: %r %s" % (line, self.err))
        self.url = line.split()[2]
        self.port = int(self.url.rsplit(":", 1)[1].strip("/"))

    def stop(self):
        if self.proc.poll() is None:
            self.proc.terminate()
        try:
            self.proc.wait(timeout=2 * START_S)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
            raise AssertionError("gonio live ignored SIGTERM")
        self.err = self.proc.stderr.read()
        self.proc.stdout.close()
        self.proc.stderr.close()
        return self.proc.returncode


# What the page shows, read in one go.
PAGE_JS = """
const s = document.getElementById('slice');
return {markers: s.querySelectorAll('circle.sample').length,
        curves: Array.from(s.querySelectorAll('path.fit')).map(p => p.getAttribute('d')),
        progress: document.getElementById('progress').textContent,
        state: document.getElementById('state').textContent,
        fitsrc: document.getElementById('fitsrc').textContent,
        errpts: document.querySelectorAll('#errplot circle.errpt').length,
        conn: document.getElementById('conn').textContent};
"""


def wait_page(drv, cond, timeout=20 * START_S / 10):
    deadline = time.time() + timeout
    while True:
        p = drv.execute_script(PAGE_JS)
        if cond(p) or time.time() > deadline:
            return p
        time.sleep(0.1)


class BrowserTests(DaemonTest):
    # slow enough that a DS3 capture (52 points) takes several seconds of
    # wall time, so that the page is seen between its fit rounds
    pace_s = 0.12

    def setUp(self):
        super().setUp()
        self.drv = browser(self.folder)

    def tearDown(self):
        self.drv.quit()
        super().tearDown()

    def test_follows_a_capture(self):
        env = dict(self.d.env, GONIO_SOCKET=self.d.sock)
        live = Live(env=env)
        try:
            self.drv.get(live.url)
            p = wait_page(self.drv, lambda p: p["conn"] == "connected")
            self.assertEqual(p["conn"], "connected")
            watch = self.d.connect()
            self.assertEqual(watch.request("watch")["class"], "OK")
            r = self.d.gonio("capture", "--plan", "ds3", "--name", "live1")
            self.assertEqual(r.returncode, 0, r.stderr)
            seen = []
            while not seen or "complete" not in seen[-1]["state"]:
                seen.append(self.drv.execute_script(PAGE_JS))
                self.assertLess(len(seen), 3000, "the page never showed the capture complete")
                time.sleep(0.05)
            docs = watch.until_stop("live1")
            events = [d for d in docs if d["class"] == "event"]
            final = wait_page(self.drv, lambda p: p["markers"] == len(events))
            shot = os.path.join(TESTS_BIN, "live-capture.png")
            self.drv.save_screenshot(shot)
        finally:
            rc = live.stop()
        self.assertEqual(rc, 0, live.err)
        self.assertEqual(len(events), 52)
        self.assertEqual(final["markers"], len(events))
        self.assertEqual(final["progress"], "52/52 points")
        # the markers grew with the events, the progress moved through
        # several values, and the curve changed while the capture ran
        running = [p for p in seen if p["state"].startswith("running")]
        self.assertGreaterEqual(len({p["progress"] for p in running}), 4, running[-3:])
        marks = [p["markers"] for p in seen]
        self.assertEqual(marks, sorted(marks))
        self.assertTrue(any(0 < m < 52 for m in marks), marks)
        curves = [tuple(p["curves"]) for p in running if p["curves"]]
        self.assertGreaterEqual(len(set(curves)), 2, "the fit curve did not change while "
                                "the capture ran")
        self.assertIn("final fit, abc.model", final["fitsrc"])
        self.assertNotEqual(tuple(final["curves"]), curves[-1])
        # the error against rig time: one point per event with a fit error
        self.assertEqual(final["errpts"], sum("fit_log_error" in e for e in events))
        self.assertGreater(final["errpts"], 0)
        with open(shot, "rb") as f:
            self.assertEqual(f.read(8), b"\x89PNG\r\n\x1a\n")
        self.assertGreater(os.path.getsize(shot), 10000)
        self.finished_capture(os.path.join(self.d.root, "live1"), final)

    def finished_capture(self, capdir, final):
        """The same capture from its directory, goniod not involved."""
        live = Live("--dir", capdir)
        try:
            self.drv.get(live.url)
            p = wait_page(self.drv, lambda p: p["markers"] == 52 and p["curves"])
        finally:
            live.stop()
        self.assertEqual(p["markers"], 52)
        self.assertEqual(p["progress"], "52/52 points")
        self.assertIn("complete", p["state"])
        self.assertIn("final fit, abc.model", p["fitsrc"])
        # the model file's curve, as the live page drew it at the stop
        self.assertEqual(p["curves"], final["curves"])


class Stream:
    """/events read as server-sent events: (event, data) pairs."""

    def __init__(self, port):
        self.c = http.client.HTTPConnection("127.0.0.1", port, timeout=3 * START_S)
        self.c.request("GET", "/events")
        self.r = self.c.getresponse()
        assert self.r.status == 200, self.r.status
        assert self.r.getheader("Content-Type") == "text/event-stream"

    def next(self, deadline):
        name, data = None, None
        while True:
            if time.time() > deadline:
                raise AssertionError("no such event in time")
            line = self.r.readline().decode()  # through the chunked coding
            if not line:
                raise AssertionError("the event stream ended")
            line = line.rstrip("\n")
            if line.startswith("event: "):
                name = line[7:]
            elif line.startswith("data: "):
                data = json.loads(line[6:])
            elif line == "" and name:
                return name, data

    def until(self, cond):
        """The data of the first event cond takes, within 3 START_S (idle
        streams send a comment line every 15 s, which ends a read)."""
        deadline = time.time() + 3 * START_S
        while True:
            name, data = self.next(deadline)
            if cond(name, data):
                return data

    def close(self):
        self.c.close()


class StreamTests(DaemonTest):
    """The stream the page reads, without a browser: pause and abort."""
    pace_s = 0.1

    def test_pause_and_abort(self):
        live = Live(env=dict(self.d.env, GONIO_SOCKET=self.d.sock))
        try:
            st = Stream(live.port)
            self.assertEqual(self.d.gonio("capture", "--plan", "ds3", "--name", "ab1")
                             .returncode, 0)
            st.until(lambda n, d: n == "samples" and d["rows"])
            self.assertEqual(self.d.gonio("pause").returncode, 0)
            st.until(lambda n, d: n == "info" and d["state"] == "paused")
            self.assertEqual(self.d.gonio("abort").returncode, 0)
            info = st.until(lambda n, d: n == "info" and d["state"] == "aborted")
            self.assertEqual(info["reason"], "aborted")
            self.assertTrue(any(a.startswith("capture aborted") for a in info["alarms"]),
                            info["alarms"])
            self.assertNotIn("results", info)
            st.close()
        finally:
            self.assertEqual(live.stop(), 0, live.err)


def unsent_bytes(server_port, client_port):
    """What the kernel holds unsent on gonio live's side of the connection
    from client_port (/proc/net/tcp's tx_queue), or None."""
    for path in ("/proc/net/tcp", "/proc/net/tcp6"):
        try:
            with open(path) as f:
                lines = f.read().splitlines()[1:]
        except OSError:
            continue
        for line in lines:
            f = line.split()
            local, remote = f[1].rsplit(":", 1)[1], f[2].rsplit(":", 1)[1]
            if int(local, 16) == server_port and int(remote, 16) == client_port:
                return int(f[4].split(":")[0], 16)
    return None


class SlowReaderTests(DaemonTest):
    """A browser that stops reading /events slows neither goniod's capture
    nor gonio live's other readers."""

    def test_stalled_reader(self):
        live = Live(env=dict(self.d.env, GONIO_SOCKET=self.d.sock))
        stalled = socket.socket()
        try:
            stalled.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1024)
            stalled.connect(("127.0.0.1", live.port))
            stalled.sendall(b"GET /events HTTP/1.1\r\nHost: localhost\r\n\r\n")
            st = Stream(live.port)
            r = self.d.gonio("capture", "--plan", "ds1", "--name", "slow1", "--wait", "--quiet")
            self.assertEqual(r.returncode, 0, r.stderr + r.stdout)
            # the reading client saw all of it, the stalled one still holds
            # its connection with data it has not taken
            info = st.until(lambda n, d: n == "info" and d["state"] == "complete")
            self.assertEqual(info["capture_id"], "slow1")
            st.close()
            pending = unsent_bytes(live.port, stalled.getsockname()[1])
            sys.stderr.write("stalled reader: %r bytes unsent\n" % pending)
            if pending is not None:  # /proc/net/tcp readable: the stall was real
                self.assertGreater(pending, 0)
            c = http.client.HTTPConnection("127.0.0.1", live.port, timeout=2 * START_S)
            c.request("GET", "/")
            self.assertEqual(c.getresponse().status, 200)
            c.close()
        finally:
            stalled.close()
            self.assertEqual(live.stop(), 0, live.err)


class RequestTests(DaemonTest):
    def status(self, port, method, path, body=None, headers=None):
        c = http.client.HTTPConnection("127.0.0.1", port, timeout=2 * START_S)
        c.request(method, path, body=body, headers=headers or {})
        r = c.getresponse()
        r.read()
        c.close()
        return r.status

    def test_bad_requests(self):
        live = Live(env=dict(self.d.env, GONIO_SOCKET=self.d.sock))
        try:
            self.assertEqual(self.status(live.port, "GET", "/"), 200)
            self.assertEqual(self.status(live.port, "GET", "/nope"), 404)
            self.assertEqual(self.status(live.port, "GET", "/../etc/passwd"), 404)
            self.assertEqual(self.status(live.port, "POST", "/", body="x"), 405)
            self.assertEqual(self.status(live.port, "PUT", "/events"), 405)
            self.assertEqual(self.status(live.port, "DELETE", "/"), 405)
            self.assertEqual(self.status(live.port, "GET", "/", body="abc"), 413)
            # nothing above reached goniod: it is idle, no capture made
            self.assertEqual(os.listdir(self.d.root), [])
            self.assertEqual(self.status(live.port, "GET", "/"), 200)
        finally:
            self.assertEqual(live.stop(), 0, live.err)

    def test_bad_arguments(self):
        for args in (["--listen", "localhost"], ["--listen", "127.0.0.1:99999"],
                     ["--listen", "no.such.host:80"], ["--dir", "/nonexistent/c1"],
                     ["--dir", self.folder, "--socket", self.d.sock], ["extra"]):
            r = subprocess.run([GONIO, "live"] + args, capture_output=True, text=True,
                               timeout=2 * START_S)
            self.assertEqual(r.returncode, 2, (args, r.stderr))
            self.assertTrue(r.stderr.startswith("gonio live: ") or "usage" in r.stderr, r.stderr)


if __name__ == "__main__":
    missing = [what for what, ok in (("chromium", chromium()), ("chromedriver", chromedriver()),
                                     ("python3-selenium", webdriver)) if not ok]
    if "BrowserTests" in sys.argv and missing:
        print("SKIPPED: %s not found (install chromium, chromium-driver, python3-selenium): "
              "gonio live was not opened in a browser" % ", ".join(missing))
        sys.exit(77)
    unittest.main()
