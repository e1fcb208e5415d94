#!/usr/bin/env python3
"""Checks that README.md's dependency table (between <!-- deps:begin and <!-- deps:end -->) lists the
same groups and Debian packages, in the same order, as tools/deps/debian.txt, the list the Makefile
installs from. Usage: check_readme_deps.py [--self-test] [ROOT]   (exit 1 and the differences when they
disagree; --self-test: also checks that a package dropped from the README's table is caught)."""
import re
import sys
from pathlib import Path


def table_groups(path):
    groups = []
    for line in Path(path).read_text(encoding="utf-8").splitlines():
        line = line.strip()
        if line and not line.startswith("#"):
            name, *packages = line.split()
            groups.append((name, packages))
    return groups


def readme_groups(path):
    text = Path(path).read_text(encoding="utf-8")
    m = re.search(r"<!-- deps:begin.*?-->(.*?)<!-- deps:end -->", text, re.S)
    if not m:
        return None
    groups = []
    for row in m.group(1).splitlines():
        cells = [c.strip() for c in row.strip().strip("|").split("|")]
        if len(cells) >= 2 and cells[0] not in ("group", "") and not set(cells[0]) <= set("-"):
            groups.append((cells[0], cells[1].strip("`").split()))
    return groups


def main():
    args = [a for a in sys.argv[1:] if a != "--self-test"]
    root = Path(args[0] if args else Path(__file__).resolve().parent.parent)
    expected = table_groups(root / "tools/deps/debian.txt")
    shown = readme_groups(root / "README.md")
    if shown is None:
        print("README.md: no <!-- deps:begin --> ... <!-- deps:end --> table")
        return 1
    if shown != expected:
        print("README.md's dependency table differs from tools/deps/debian.txt:")
        print("  README:", shown)
        print("  debian.txt:", expected)
        return 1
    if "--self-test" in sys.argv:
        planted = [(name, packages[1:]) for name, packages in shown]
        if planted == expected:
            print("self-test: a package dropped from every README group went unnoticed")
            return 1
    print(f"README.md lists the {len(expected)} dependency groups of tools/deps/debian.txt")
    return 0


if __name__ == "__main__":
    sys.exit(main())
