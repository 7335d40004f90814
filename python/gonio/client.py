"""A client of goniod's control socket (docs/protocol.md): one JSON object
a line each way. Requests go through one connection and wait for their
reply; watch() opens a connection of its own, so a script can follow a
capture while it pauses, resumes or aborts it through the first."""
import json
import os
import socket

DEFAULT_SOCKET = "/run/goniod/goniod.sock"
PROTO_MAJOR = 1
# The fields a capture request takes and their JSON types (docs/protocol.md).
CAPTURE_FIELDS = {"plan": str, "scene": str, "material": str, "rig": str, "model": str,
                  "order": str, "stop": str, "name": str, "truth": str,
                  "sample": str, "operator": str, "note": str, "check": str,
                  "budget": (int, float), "stop_target": (int, float), "prescan": int,
                  # a plan's, rig profile's or scene's text sent with the request;
                  # plan, rig or scene then names the file (docs/protocol.md)
                  "plan_text": str, "rig_text": str, "scene_text": str}


class GonioError(Exception):
    """An ERROR reply: code (for programs, docs/protocol.md) and message."""

    def __init__(self, code, message):
        super().__init__("%s: %s" % (code, message))
        self.code = code
        self.message = message


class _Connection:
    def __init__(self, path, timeout):
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self.sock.settimeout(timeout)
        try:
            self.sock.connect(path)
        except OSError:
            self.sock.close()
            raise
        self.buf = b""
        self.version = self.read()
        if self.version is None:
            raise ConnectionError("%s: closed before its greeting" % path)
        if self.version.get("class") == "ERROR":
            self.sock.close()
            raise GonioError(self.version.get("code"), self.version.get("message"))
        if self.version.get("proto_major") != PROTO_MAJOR:
            self.sock.close()
            raise ConnectionError("%s: protocol %s, this client speaks %d" %
                                  (path, self.version.get("proto_major"), PROTO_MAJOR))

    def read(self):
        """The next line's document, None at the end of the stream."""
        while b"\n" not in self.buf:
            chunk = self.sock.recv(65536)
            if not chunk:
                return None
            self.buf += chunk
        line, self.buf = self.buf.split(b"\n", 1)
        return json.loads(line)

    def send(self, doc):
        self.sock.sendall(json.dumps(doc).encode() + b"\n")

    def close(self):
        self.sock.close()


class Client:
    """goniod at socket (default $GONIO_SOCKET, else /run/goniod/goniod.sock).
    Every call raises GonioError on an ERROR reply; timeout (seconds) bounds
    each wait for a reply, not a watch."""

    def __init__(self, socket_path=None, timeout=30.0):
        self.path = socket_path or os.environ.get("GONIO_SOCKET") or DEFAULT_SOCKET
        self.timeout = timeout
        self._conn = _Connection(self.path, timeout)
        self._next_id = 1
        self.version = self._conn.version

    def close(self):
        self._conn.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def request(self, cmd, **fields):
        """Send one request and return its reply (OK or STATUS)."""
        rid = self._next_id
        self._next_id += 1
        self._conn.send(dict(fields, cmd=cmd, id=rid))
        while True:
            d = self._conn.read()
            if d is None:
                raise ConnectionError("goniod closed the connection awaiting '%s'" % cmd)
            if isinstance(d, dict) and d.get("id") == rid:
                if d.get("class") == "ERROR":
                    raise GonioError(d.get("code"), d.get("message"))
                return d

    def status(self):
        return self.request("status")

    def capture(self, plan, **fields):
        """Start a capture: plan and any of CAPTURE_FIELDS. Returns the reply
        (capture_id, dir). A field goniod does not take, or of the wrong
        type, is refused here as goniod would (GonioError)."""
        fields["plan"] = plan
        for k, v in fields.items():
            if k not in CAPTURE_FIELDS:
                raise GonioError("unknown-field", "capture: unknown field '%s' (takes %s)" %
                                 (k, ", ".join(CAPTURE_FIELDS)))
            if not isinstance(v, CAPTURE_FIELDS[k]) or isinstance(v, bool):
                raise GonioError("bad-type", "capture: field '%s' %r: wrong type" % (k, v))
        return self.request("capture", **fields)

    def pause(self):
        return self.request("pause")

    def resume(self, capture_id=None):
        """Resume the paused capture, or (capture_id) a capture directory."""
        return self.request("resume", **({"capture_id": capture_id} if capture_id else {}))

    def abort(self):
        return self.request("abort")

    def list(self):
        """The captures goniod knows: the `captures` array of the list reply."""
        return self.request("list")["captures"]

    def watch(self, format="event-model", until_stop=True):
        """The capture stream on a connection of its own: a generator of
        (name, doc) pairs for format event-model (Bluesky's callbacks take
        them as they are), of documents for format stream. Subscribed when
        watch returns, so a capture started after it is seen whole (a run
        already going: from its start and descriptor). With until_stop it
        ends after a run's stop, else when goniod closes."""
        conn = _Connection(self.path, self.timeout)
        try:
            conn.send({"cmd": "watch", "format": format, "id": 0})
            reply = conn.read()
            if reply is None:
                raise ConnectionError("goniod closed the connection awaiting 'watch'")
            if reply.get("class") == "ERROR":
                raise GonioError(reply.get("code"), reply.get("message"))
        except BaseException:
            conn.close()
            raise
        conn.sock.settimeout(None)  # a capture may take hours between documents
        return self._follow(conn, until_stop)

    @staticmethod
    def _follow(conn, until_stop):
        try:
            while True:
                d = conn.read()
                if d is None:
                    return
                item = tuple(d) if isinstance(d, list) else d
                yield item
                stop = item[0] == "stop" if isinstance(item, tuple) else item.get("class") == "stop"
                if until_stop and stop:
                    return
        finally:
            conn.close()
