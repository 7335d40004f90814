#!/usr/bin/python3
"""The library layering of docs/architecture.md, checked: every quoted
#include in a library folder names its own folder or one of the folders it
may use. A library that reaches up (drivers including the planner, the
journal including the fitter) fails here with the file, the line and the
rule it breaks.

Run from anywhere: python3 check_layering.py [SOURCE_DIR]"""
import os
import re
import sys

# Each library folder and the folders below it that it may include. Keep in
# step with the table in docs/architecture.md.
ALLOWED = {
    "common": set(),
    "brdf": {"common"},
    "rig": {"common"},
    "modbus_map": set(),
    "journal": {"brdf", "common"},
    "planner": {"rig", "brdf", "common"},
    "fit": {"journal", "brdf", "common"},
    "adaptive": {"fit", "planner", "rig", "brdf", "journal", "common"},
    "sim": {"planner", "modbus_map", "rig", "brdf", "common"},
    "drivers": {"modbus_map", "sim", "rig", "brdf", "common"},
    "capture": {"adaptive", "drivers", "sim", "fit", "journal", "planner", "rig", "brdf",
                "common"},
    "daemon": {"capture", "adaptive", "drivers", "sim", "fit", "journal", "planner", "rig",
               "brdf", "common"},
    "render": {"fit", "planner", "rig", "brdf", "common"},
    "report": {"fit", "journal", "planner", "rig", "brdf", "common"},
    "study": {"capture", "adaptive", "drivers", "sim", "fit", "journal", "planner", "rig",
              "brdf", "common"},
}
# Inside drivers/ the in-process simulator backend alone may see sim/: the
# core and the Modbus and USB backends must not.
SIM_BACKEND = {"drv_sim.c", "drv_sim.h"}

INCLUDE = re.compile(r'^\s*#\s*include\s+"([a-z_]+)/')


def violations(root):
    found = []
    for lib, allowed in sorted(ALLOWED.items()):
        folder = os.path.join(root, lib)
        if not os.path.isdir(folder):
            found.append(f"{lib}/: the folder is missing (layering table out of date?)")
            continue
        for name in sorted(os.listdir(folder)):
            if not name.endswith((".c", ".h")):
                continue
            with open(os.path.join(folder, name), encoding="utf-8") as f:
                for lineno, line in enumerate(f, 1):
                    m = INCLUDE.match(line)
                    if not m or m.group(1) == lib:
                        continue
                    used = m.group(1)
                    ok = used in allowed
                    if lib == "drivers" and used == "sim":
                        ok = name in SIM_BACKEND
                    if not ok:
                        found.append(f"{lib}/{name}:{lineno}: includes {used}/, which "
                                     f"{lib}/ may not use ({line.strip()})")
    return found


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else os.path.join(
        os.path.dirname(os.path.abspath(__file__)), "..", "..")
    bad = violations(root)
    for line in bad:
        print(line)
    print(f"layering: {len(bad)} violation(s) in {len(ALLOWED)} libraries")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
