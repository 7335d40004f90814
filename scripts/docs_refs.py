#!/usr/bin/python3
"""docs-check's reference check: every path a document or a source comment
names (`drivers/drv_modbus.h`, `docs/plans.md`) or links to (`[x](plans.md)`)
exists in the tree, and
every section it cites (`docs/plans.md, "Reachability"`) is a heading of
that document. Prints each broken reference as FILE:LINE: what, and exits 1
when there is one.

  docs_refs.py [REPO_ROOT]

A path is a word that starts with one of the repository's top-level
folders and ends in a file extension; words with a wildcard or a
placeholder (test_*.c, configs/rigs/NAME.yaml) are patterns, not references. A section
matches a heading of the document when the heading, without its #s and
backticks, equals it or starts with it followed by a space, a colon, a comma or a
parenthesis. README.md's source layout must list every top-level folder.
"""
import os
import re
import subprocess
import sys

EXT = r"(?:c|h|md|sh|py|yaml|yml|json|txt|cmake|csv|supp|service|in|spec|html|svg|png)"
SCANNED = re.compile(r"(\.(md|c|h|sh|py|cmake|txt|yaml)|Makefile)$")
LINK = re.compile(r"\]\(([^)\s]+)\)")
SECTION = re.compile(r"(?<![\w/.-])((?:docs/)?(?:notes/)?[\w-]+\.md)[`)]*,? +(?:section +)?\"([^\"\n]{2,100})\"")


def tracked(root):
    """The repository's files: git's list, or outside a git checkout (a
    release tarball) every file but the build folders'."""
    try:
        out = subprocess.run(["git", "ls-files", "-z"], cwd=root, check=True,
                             capture_output=True).stdout.decode()
        return [f for f in out.split("\0") if f]
    except (OSError, subprocess.CalledProcessError):
        files = []
        for folder, dirs, names in os.walk(root):
            dirs[:] = [d for d in dirs if not d.startswith((".", "build", "out"))]
            files += [os.path.relpath(os.path.join(folder, n), root) for n in names]
        return files


def headings(path, cache={}):
    if path not in cache:
        heads = []
        try:
            with open(path, encoding="utf-8") as f:
                fence = False
                for line in f:
                    if line.startswith("```"):
                        fence = not fence
                    elif not fence and line.startswith("#"):
                        heads.append(line.lstrip("#").strip().replace("`", "").lower())
        except OSError:
            pass
        cache[path] = heads
    return cache[path]


def section_exists(doc, section):
    s = section.replace("`", "").lower().rstrip(".")
    for h in headings(doc):
        if h == s or (h.startswith(s) and h[len(s)] in " :(,"):
            return True
    return False


def check_layout(root, tops):
    """README.md's "Source layout" table names every top-level folder of
    the tree, and no folder the tree does not have."""
    text = open(os.path.join(root, "README.md"), encoding="utf-8").read()
    m = re.search(r"^## Source layout\n(.*?)(?=^## |\Z)", text, re.M | re.S)
    if not m:
        print('README.md: no "Source layout" section')
        return 1
    listed = set(re.findall(r"^\| `([\w.-]+)/` \|", m.group(1), re.M))
    bad = 0
    for d in sorted(set(tops) - listed):
        print("README.md: the source layout does not list %s/" % d)
        bad += 1
    for d in sorted(listed - set(tops)):
        print("README.md: the source layout lists %s/, which the tree does not have" % d)
        bad += 1
    return bad


def main():
    root = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else ".")
    files = tracked(root)
    tops = sorted({f.split("/")[0] for f in files if "/" in f} - {".ci", ".github"})
    path_re = re.compile(r"(?<![\w./-])((?:%s)/[\w./+-]*\.%s)(?![\w*/-]|\.\w)"
                         % ("|".join(map(re.escape, tops)), EXT))
    present = set(files)
    dirs = {os.path.dirname(f) for f in files}
    bad = 0
    for f in files:
        if not SCANNED.search(f) or f.startswith(("fuzz/corpus/", "tests/data/")):
            continue
        try:
            text = open(os.path.join(root, f), encoding="utf-8").read()
        except (OSError, UnicodeDecodeError):
            continue
        for n, line in enumerate(text.splitlines(), 1):
            for m in path_re.finditer(line):
                p = m.group(1).rstrip(".")
                if re.search(r"[*{}<>]|\.\.\.|(^|[/_])[A-Z]+\.", p):
                    continue
                if p not in present and p not in dirs and not os.path.exists(os.path.join(root, p)):
                    print("%s:%d: no such file: %s" % (f, n, p))
                    bad += 1
            for m in LINK.finditer(line) if f.endswith(".md") else ():
                target = m.group(1).split("#")[0]
                if not target or re.match(r"[a-z]+:", target):
                    continue
                if not os.path.exists(os.path.join(root, os.path.dirname(f), target)):
                    print("%s:%d: the link to %s leads nowhere" % (f, n, target))
                    bad += 1
            for m in SECTION.finditer(line):
                doc, section = m.group(1), m.group(2)
                if not doc.startswith("docs/"):
                    doc = "docs/" + doc  # a bare name is a page of docs/
                if doc not in present:
                    continue  # a missing document is reported as a path
                if not section_exists(os.path.join(root, doc), section):
                    print('%s:%d: %s has no section "%s"' % (f, n, doc, section))
                    bad += 1
    bad += check_layout(root, tops)
    if bad:
        print("docs-check: %d broken reference(s)" % bad)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
