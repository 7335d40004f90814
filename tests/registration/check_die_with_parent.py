#!/usr/bin/python3
"""Every helper process a test starts dies with the test: a Python test's
subprocess.Popen passes preexec_fn=...die_with_parent and a pty.fork or
os.fork child calls die_with_parent() before anything else
(tests/child_procs.py); a C test forks through gonio_test_fork()
(tests/gonio_test.h), never fork() itself. Otherwise a test that crashes or
hits its ctest TIMEOUT can leave a helper holding a lock, a port or
ctest's output pipe. Fails naming each file and line that starts a helper
another way.

  check_die_with_parent.py SOURCE_DIR
"""
import ast
import os
import re
import sys

# The one place a C test may call fork() itself.
C_FORK_HOME = os.path.join("tests", "gonio_test.h")


def python_starts(path):
    """(line, call) of each helper start in path without the parent-death
    signal."""
    tree = ast.parse(open(path).read(), path)
    bad = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.Call):
            continue
        name = ast.unparse(node.func)
        if name.endswith("Popen"):
            fn = [k.value for k in node.keywords if k.arg == "preexec_fn"]
            if not fn or not ast.unparse(fn[0]).endswith("die_with_parent"):
                bad.append((node.lineno, name))
        elif name in ("pty.fork", "os.fork", "os.forkpty"):
            bad.append((node.lineno, name))  # accepted below when the child asks at once
    return [b for b in bad if not child_asks(tree, b)]


def child_asks(tree, start):
    """A fork whose child branch (if pid == 0:) calls die_with_parent first,
    directly or inside a try."""
    line, name = start
    if name.endswith("Popen"):
        return False
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and node.lineno > line and node.lineno <= line + 2:
            body = node.body
            while body and isinstance(body[0], ast.Try):
                body = body[0].body
            return bool(body) and "die_with_parent" in ast.unparse(body[0])
    return False


def c_forks(path):
    text = open(path, errors="replace").read()
    return [(text.count("\n", 0, m.start()) + 1, "fork()")
            for m in re.finditer(r"(?<![\w.])fork\s*\(\s*\)", text)]


def main():
    source = sys.argv[1]
    found = []
    for folder, dirs, files in os.walk(os.path.join(source, "tests")):
        dirs[:] = [d for d in dirs if d != "__pycache__"]
        for f in sorted(files):
            path = os.path.join(folder, f)
            rel = os.path.relpath(path, source)
            if f.endswith(".py"):
                found += [(rel, *b) for b in python_starts(path)]
            elif f.endswith((".c", ".h")) and rel != C_FORK_HOME:
                found += [(rel, *b) for b in c_forks(path)]
    for rel, line, what in found:
        print("%s:%d: %s starts a helper without the parent-death signal (use "
              "preexec_fn=child_procs.die_with_parent, child_procs.die_with_parent() in the "
              "child, or gonio_test_fork())" % (rel, line, what))
    print("%d helper start(s) without the parent-death signal" % len(found))
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
