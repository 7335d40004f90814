"""A calibration run's event-model documents (docs/protocol.md, "Calibrations
as event-model documents") held to Bluesky's published schemas
(../shared/anchors/event-model, python3-jsonschema) and to the calibration
they describe: its calibration.json and frames.csv, frame for frame. Shared
by the offline (tests/cli) and goniod (tests/daemon) tests."""
import csv
import json
import os
import statistics

try:
    import jsonschema
except ImportError:  # Debian's python3-jsonschema (scripts/deps.sh)
    jsonschema = None

SOURCE = os.environ.get("GONIO_SOURCE",
                        os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SHARED = os.environ.get("GONIO_SHARED", os.path.join(SOURCE, "..", "shared"))
SCHEMAS = os.path.join(SHARED, "anchors", "event-model")
SCHEMA_FILES = {"start": "run_start.json", "descriptor": "event_descriptor.json",
                "event": "event.json", "stop": "run_stop.json"}


def validators():
    """A validator per document name, or (None, why to skip)."""
    if jsonschema is None:
        return None, "python3-jsonschema not installed (SKIPPED: event-model schemas)"
    if not os.path.isdir(SCHEMAS):
        return None, "%s missing (SKIPPED: event-model schemas)" % SCHEMAS
    out = {}
    for name, f in SCHEMA_FILES.items():
        with open(os.path.join(SCHEMAS, f)) as fh:
            out[name] = jsonschema.Draft202012Validator(json.load(fh))
    return out, None


def read_documents(cal_dir):
    """The [name, doc] pairs of cal_dir/documents.jsonl, one run after another."""
    with open(os.path.join(cal_dir, "documents.jsonl")) as f:
        return [tuple(json.loads(line)) for line in f]


def close(a, b):
    return a is None and b is None or abs(a - b) <= 1e-9 * max(1.0, abs(b))


def check_run(pairs, cal_dir, v):
    """Check one run's pairs (start .. stop) of the calibration in cal_dir
    with validators v; returns (start, stop, {stream: (descriptor, events)}).
    Raises AssertionError naming what is wrong."""
    for name, doc in pairs:
        errors = [e.message for e in v[name].iter_errors(doc)]
        assert not errors, "%s invalid: %s (%s)" % (name, errors, json.dumps(doc)[:400])
    assert pairs[0][0] == "start" and pairs[-1][0] == "stop", [p[0] for p in pairs]
    start, stop = pairs[0][1], pairs[-1][1]
    streams = {}
    by_uid = {}
    for name, doc in pairs[1:-1]:
        if name == "descriptor":
            assert doc["run_start"] == start["uid"]
            streams[doc["name"]] = (doc, [])
            by_uid[doc["uid"]] = doc["name"]
        else:
            assert name == "event", name
            streams[by_uid[doc["descriptor"]]][1].append(doc)
    assert stop["run_start"] == start["uid"]
    assert stop["num_events"] == {k: len(e) for k, (_, e) in streams.items()}, stop
    meta = json.load(open(os.path.join(cal_dir, "calibration.json"))) \
        if stop["exit_status"] == "success" else None
    if meta:
        assert start["calibration_id"] == meta["id"]
        for key in ("kind", "rig", "detector", "valid_s"):
            assert start[key] == meta[key], (key, start[key], meta[key])
        assert start["valid_until"] == start["created"] + meta["valid_s"]
        assert start["dark"] == (meta.get("dark") or None)
    for stream, (desc, events) in streams.items():
        for k, e in enumerate(events):
            assert e["seq_num"] == k + 1
            assert set(e["data"]) == set(desc["data_keys"]), (stream, sorted(e["data"]))
            for key, value in e["data"].items():
                shape = desc["data_keys"][key]["shape"]
                if shape:
                    assert len(value) == shape[0], (key, value)
    if "primary" in streams and meta:
        check_frames(streams["primary"][1], os.path.join(cal_dir, "frames.csv"))
    if "results" in streams:
        check_results(streams["results"][1], streams["primary"][1], start["kind"])
    return start, stop, streams


def check_frames(events, frames_csv):
    """Every frame of frames.csv is an event, in order, its counts as read."""
    rows = list(csv.DictReader(open(frames_csv)))
    assert len(events) == len(rows), (len(events), len(rows))
    for e, r in zip(events, rows):
        d = e["data"]
        assert [close(d["counts"][c], float(r[ch])) for c, ch in enumerate("rgb")] == [True] * 3,\
            (d, r)
        assert close(d["integration_s"], float(r["integration_s"]))
        assert d["gain_state"] == int(r["gain_state"])
        if r.get(None):  # a spectral detector's bands: the unnamed last field, nm:counts
            bands = [float(x.split(":")[1]) for x in r[None][0].split()]
            assert len(d["bands"]) == len(bands)
            assert all(close(a, b) for a, b in zip(d["bands"], bands)), (d["bands"], bands)


def check_results(results, frames, kind):
    """Each results event: the mean and spread of its group's frames."""
    groups = {}
    for e in frames:
        d = e["data"]
        key = (d["integration_s"], d["gain_state"]) + \
            (() if kind == "dark" else (d["theta_i"], d["theta_r"]))
        groups.setdefault(key, []).append(d)
    assert len(results) == len(groups), (len(results), len(groups))
    for e in results:
        d = e["data"]
        key = (d["integration_s"], d["gain_state"]) + \
            (() if kind == "dark" else (d["theta_i"], d["theta_r"]))
        members = groups[key]
        assert d["frames"] == len(members)
        for c in range(3):
            values = [m["counts"][c] for m in members]
            assert close(d["mean"][c], statistics.mean(values)), (d, values)
            if len(values) > 1:
                assert abs(d["sd"][c] - statistics.stdev(values)) <= 1e-6 * (1 + d["sd"][c])
        if "band_mean" in d:
            for k in range(len(d["band_mean"])):
                values = [m["bands"][k] for m in members]
                assert close(d["band_mean"][k], statistics.mean(values))
