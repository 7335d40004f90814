"""A capture directory read into arrays (docs/formats.md): samples.csv by
column, and the JSON files beside it."""
import csv
import json
import os
import zlib

from . import _arrays


class Capture:
    """dir; samples: {column: array} (every column of samples.csv but its
    CRC: flags, point and gain_state as integers, unit as strings, an empty
    field (none) as nan; rgb also as an (n, 3) array under "rgb"); plan, setup, results, request: the JSON files (None when
    absent); model_file: the final fit's model file path, or None; checks:
    results.json's premise checks' verdicts ({} when none ran); auto: its
    --model auto choice and why (None for another model)."""

    def __init__(self, path, samples, docs):
        self.dir = path
        self.samples = samples
        self.plan = docs.get("plan.json")
        self.setup = docs.get("setup.json")
        self.results = docs.get("results.json")
        self.request = docs.get("request.json")
        name = (self.results or {}).get("model_file")
        self.model_file = os.path.join(path, name) if name else None
        self.checks = (self.results or {}).get("checks") or {}
        self.auto = (self.results or {}).get("auto")

    def __len__(self):
        return len(self.samples.get("point", []))


INT_COLUMNS = ("point", "flags", "gain_state")
TEXT_COLUMNS = ("unit",)


def _number(v):
    return float(v) if v != "" else float("nan")


def _read_samples(path):
    """samples.csv's columns; the CRC chain checked (ValueError naming the
    line where it breaks), as gonio's own reader does for the current
    format."""
    with open(path, newline="") as f:
        text = f.read()
    lines = text.split("\n")
    header = lines[0].split(",")
    chained = header[-1] == "chain_crc32"
    crc = zlib.crc32((lines[0] + "\n").encode()) if chained else 0
    records = []
    for no, line in enumerate(lines[1:], 2):
        if not line:
            continue
        if no == len(lines):  # no newline after it: a torn record
            break
        head, _, given = line.rpartition(",")
        body = (head + ",").encode()
        crc = zlib.crc32(body, crc) if chained else zlib.crc32(body)
        if given.lower() != "%08x" % crc:
            raise ValueError("%s:%d: CRC does not match (edited or corrupt journal)" % (path, no))
        records.append(next(csv.reader([head])))
    columns = {}
    for i, name in enumerate(header[:-1]):
        values = [r[i] for r in records]
        if name in TEXT_COLUMNS:
            columns[name] = values
        elif name in INT_COLUMNS:
            columns[name] = [int(v) if v != "" else 0 for v in values]
        else:
            columns[name] = _arrays.array([_number(v) for v in values])
    if {"r", "g", "b"} <= set(columns):
        at = [header.index(c) for c in "rgb"]
        columns["rgb"] = _arrays.rows([_number(r[i]) for r in records for i in at], 3)
    return columns


def read_capture(path):
    """The capture directory at path (a Capture)."""
    samples = _read_samples(os.path.join(path, "samples.csv"))
    docs = {}
    for name in ("plan.json", "setup.json", "results.json", "request.json"):
        p = os.path.join(path, name)
        if os.path.exists(p):
            with open(p) as f:
                docs[name] = json.load(f)
    return Capture(path, samples, docs)
