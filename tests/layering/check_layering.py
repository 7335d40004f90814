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
    "radiometry": {"brdf", "common"},
    "planner": {"rig", "brdf", "common"},
    "fit": {"journal", "brdf", "common"},
    "adaptive": {"fit", "planner", "rig", "brdf", "journal", "common"},
    "sim": {"planner", "modbus_map", "rig", "brdf", "common"},
    "drivers": {"modbus_map", "sim", "rig", "brdf", "common"},
    "capture": {"radiometry", "adaptive", "drivers", "fit", "journal", "planner", "rig", "brdf", "common"},
    "sim_source": {"radiometry", "capture", "adaptive", "drivers", "sim", "fit", "journal", "planner", "rig",
                   "brdf", "common"},
    "daemon": {"radiometry", "sim_source", "capture", "adaptive", "drivers", "sim", "fit", "journal",
               "planner", "rig", "brdf", "common"},
    "render": {"fit", "planner", "rig", "brdf", "common"},
    "python": {"fit", "journal", "brdf", "common"},
    "report": {"fit", "journal", "planner", "rig", "brdf", "common"},
    "study": {"radiometry", "sim_source", "capture", "adaptive", "drivers", "sim", "fit", "journal", "planner", "rig",
              "brdf", "common"},
}
# goniod names the Modbus registers its event-model documents' data come
# from (daemon/control_events.c).
ALLOWED["daemon"].add("modbus_map")
# Inside drivers/ the in-process simulator backend alone may see sim/: the
# core and the Modbus and USB backends must not.
SIM_BACKEND = {"drv_sim.c", "drv_sim.h"}

INCLUDE = re.compile(r'^\s*#\s*include\s+"([a-z_]+)/')
# CMake: the libraries a folder builds and the gonio_* targets it links.
ADD_LIBRARY = re.compile(r'add_library\(\s*(gonio_[a-z_]+)')
LINK = re.compile(r'target_link_libraries\(([^)]*)\)', re.S)
TARGET = re.compile(r'\b(gonio_[a-z_]+)')
VARIANT = "${variant}"


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


def cmake_text(root, lib):
    path = os.path.join(root, lib, "CMakeLists.txt")
    if not os.path.exists(path):
        return ""
    with open(path, encoding="utf-8") as f:
        return f.read().replace(VARIANT, "")


def link_violations(root):
    """Each library folder links only the libraries of the folders it may
    include (the test variant of a library counts as the library)."""
    owner = {}
    for lib in ALLOWED:
        for target in ADD_LIBRARY.findall(cmake_text(root, lib)):
            owner[target] = lib
            owner[target + "_test_hooks"] = lib
    found = []
    for lib, allowed in sorted(ALLOWED.items()):
        for args in LINK.findall(cmake_text(root, lib)):
            for target in TARGET.findall(args):
                used = owner.get(target)
                if used and used != lib and used not in allowed:
                    found.append(f"{lib}/CMakeLists.txt: links {target} of {used}/, which "
                                 f"{lib}/ may not use")
    return found


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else os.path.join(
        os.path.dirname(os.path.abspath(__file__)), "..", "..")
    bad = violations(root) + link_violations(root)
    for line in bad:
        print(line)
    print(f"layering: {len(bad)} violation(s) in {len(ALLOWED)} libraries")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
