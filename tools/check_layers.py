#!/usr/bin/env python3
"""The include rule of docs/architecture.md, checked on the source tree.

Reads tools/layers.txt (rank, layer, folders and public headers), assigns every source and header under
src/, include/, apps/ and python/src/ to a layer, resolves each of its #include "..." lines and fails when
a file includes a header of a higher layer, of a sibling layer of the same rank, or a header that does
not exist; also when a file belongs to no layer.

  check_layers.py --root DIR               check the tree at DIR
  check_layers.py --root DIR --self-test   also plant violations in a copy and check that each is caught
"""
import argparse
import os
import re
import shutil
import sys
import tempfile

CHECKED_DIRS = ("src", "include", "apps", "python/src")
SOURCE_SUFFIXES = (".cpp", ".hpp", ".h", ".cc")
INCLUDE = re.compile(r'^\s*#\s*include\s*([<"])([^>"]+)[>"]')
# Where "kfx/..." headers live: the installed API, then the reproduce target's own (not installed) header.
KFX_HEADER_DIRS = ("include", "src/reproduce/include")


class Layers:
    def __init__(self, table_path):
        self.rank = {}  # layer -> rank
        self.paths = []  # (path relative to root, layer), folders and files
        with open(table_path, encoding="utf-8") as f:
            for number, line in enumerate(f, 1):
                line = line.split("#", 1)[0].strip()
                if not line:
                    continue
                fields = line.split()
                if len(fields) < 3 or not fields[0].isdigit():
                    raise SystemExit(f"{table_path}:{number}: expected 'rank layer paths...'")
                rank, layer = int(fields[0]), fields[1]
                if layer in self.rank:
                    raise SystemExit(f"{table_path}:{number}: layer {layer} listed twice")
                self.rank[layer] = rank
                for p in fields[2:]:
                    self.paths.append((p.rstrip("/"), layer))
        # Longest path first: a file belongs to the most specific entry.
        self.paths.sort(key=lambda e: -len(e[0]))

    def layer_of(self, rel):
        for p, layer in self.paths:
            if rel == p or rel.startswith(p + "/"):
                return layer
        return None


def source_files(root):
    for top in CHECKED_DIRS:
        base = os.path.join(root, top)
        for dirpath, dirnames, filenames in os.walk(base):
            dirnames.sort()
            for name in sorted(filenames):
                if name.endswith(SOURCE_SUFFIXES):
                    yield os.path.relpath(os.path.join(dirpath, name), root).replace(os.sep, "/")


def resolve(root, including, target):
    """Path (relative to root) of the header that `#include "target"` in `including` names, or None."""
    candidates = []
    if target.startswith("kfx/"):
        candidates += [f"{d}/{target}" for d in KFX_HEADER_DIRS]
    else:
        candidates.append(os.path.normpath(os.path.join(os.path.dirname(including), target)).replace(os.sep, "/"))
        candidates.append(f"src/{target}")
    for c in candidates:
        if os.path.isfile(os.path.join(root, c)):
            return c
    return None


def check(root, table):
    layers = Layers(table)
    problems = []
    for rel in source_files(root):
        layer = layers.layer_of(rel)
        if layer is None:
            problems.append(f"{rel}: belongs to no layer of {os.path.relpath(table, root)}")
            continue
        with open(os.path.join(root, rel), encoding="utf-8", errors="replace") as f:
            for number, line in enumerate(f, 1):
                m = INCLUDE.match(line)
                if not m:
                    continue
                bracket, target = m.groups()
                if bracket == "<" and not target.startswith("kfx/"):
                    continue  # system and third-party headers
                header = resolve(root, rel, target)
                if header is None:
                    problems.append(f"{rel}:{number}: #include \"{target}\" names no file of the tree")
                    continue
                other = layers.layer_of(header)
                if other is None:
                    problems.append(f"{rel}:{number}: {header} belongs to no layer")
                elif other == layer:
                    continue
                elif layers.rank[other] > layers.rank[layer]:
                    problems.append(f"{rel}:{number}: layer {layer} (rank {layers.rank[layer]}) includes {header} "
                                    f"of the higher layer {other} (rank {layers.rank[other]})")
                elif layers.rank[other] == layers.rank[layer]:
                    problems.append(f"{rel}:{number}: layer {layer} includes {header} of its sibling layer {other}")
    return problems


def plant(root, rel, text):
    path = os.path.join(root, rel)
    with open(path, "a", encoding="utf-8") as f:
        f.write(text)


def self_test(root, table):
    """Each planted violation must be reported; the copy without them must pass."""
    cases = [
        ("upward include", "src/base/validation.cpp", '#include "kfx/io.hpp"\n'),
        ("upward include of a private header", "src/core/model.cpp", '#include "methods/block_diagonal/block_diagonal_internal.hpp"\n'),
        ("sibling include", "src/methods/mismatch/mismatch.cpp", '#include "kfx/block_diagonal.hpp"\n'),
        ("include of a missing file", "src/io/npy.cpp", '#include "kfx/no_such_header.hpp"\n'),
        ("file in no layer", None, None),
    ]
    failures = []
    for name, rel, text in cases:
        with tempfile.TemporaryDirectory() as tmp:
            for top in CHECKED_DIRS + ("tools",):
                shutil.copytree(os.path.join(root, top), os.path.join(tmp, top))
            if rel is None:
                with open(os.path.join(tmp, "src", "stray.cpp"), "w", encoding="utf-8") as f:
                    f.write("int stray;\n")
            else:
                plant(tmp, rel, text)
            where = rel or "src/stray.cpp"
            caught = [c for c in check(tmp, os.path.join(tmp, "tools", "layers.txt")) if c.startswith(where + ":")]
            if not caught:
                failures.append(f"self-test: a planted {name} was not reported")
            else:
                print(f"self-test: planted {name}: reported ({caught[0]})")
    return failures


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--root", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
    parser.add_argument("--table", help="the layer table (default: ROOT/tools/layers.txt)")
    parser.add_argument("--self-test", action="store_true")
    args = parser.parse_args()
    root = os.path.abspath(args.root)
    table = args.table or os.path.join(root, "tools", "layers.txt")
    problems = check(root, table)
    files = sum(1 for _ in source_files(root))
    if args.self_test:
        problems += self_test(root, table)
    for p in problems:
        print(p, file=sys.stderr)
    if problems:
        print(f"check_layers: {len(problems)} problem(s)", file=sys.stderr)
        return 1
    print(f"check_layers: {files} files follow the include rule of {os.path.relpath(table, root)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
