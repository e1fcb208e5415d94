#!/usr/bin/env python3
"""Cohesive files (docs/architecture.md): no source file of the library, the CLI or the bindings above
600 lines unless its header comment says the one job it does ("One job: ..."), and no function above
150 lines.

  check_sizes.py --root DIR               report every violation; exit 1 if there is one
  check_sizes.py --root DIR --self-test   also check that a long function and a long file are caught

Functions are found from their bodies: a line ending in "{" at namespace level (indentation 0) or as
a class member (indentation 2) that opens a function (not a class, struct, enum, namespace or an
initializer), up to the line that closes it at the same indentation. Lambdas inside a function count
toward that function.
"""
import argparse
import os
import re
import sys
import tempfile

CHECKED_DIRS = ("src", "include", "apps", "python/src")
SUFFIXES = (".cpp", ".hpp", ".h", ".cc")
MAX_FILE_LINES = 600
MAX_FUNCTION_LINES = 150
ONE_JOB = re.compile(r"^//.*\bOne job:", re.IGNORECASE)
NOT_A_FUNCTION = re.compile(r"^\s*(namespace|class|struct|enum|union|extern|template\s*<[^>]*>\s*(class|struct))\b")


def sources(root):
    for top in CHECKED_DIRS:
        for dirpath, dirnames, filenames in os.walk(os.path.join(root, top)):
            dirnames.sort()
            for name in sorted(filenames):
                if name.endswith(SUFFIXES):
                    yield os.path.join(dirpath, name)


def header_comment(lines):
    out = []
    for line in lines:
        if line.startswith("//") or line.startswith("#pragma"):
            out.append(line)
        elif line.strip() == "":
            continue
        else:
            break
    return out


def function_name(lines, i):
    """The identifier before the parameter list of the declaration that ends at line i."""
    text = "".join(lines[max(0, i - 4):i + 1])
    text = re.split(r"[;}]\s*\n|\*/|^\s*//.*$", text, flags=re.M)[-1]
    m = re.search(r"([A-Za-z_][\w:~]*)\s*\(", text)
    return m.group(1) if m else "?"


def functions(lines):
    """(name, first line, length) of each function body opened at indentation 0 or 2."""
    found = []
    i = 0
    while i < len(lines):
        line = lines[i].rstrip("\n")
        indent = len(line) - len(line.lstrip(" "))
        if indent in (0, 2) and line.endswith("{") and "(" in "".join(lines[max(0, i - 4):i + 1]) and \
                not NOT_A_FUNCTION.match(line) and not line.lstrip().startswith(("//", "#", "}", "=")) and \
                not re.search(r"(=|\breturn)\s*\{$", line) and not re.search(r"\b(if|for|while|switch|else|do|try)\b", line):
            closing = " " * indent + "}"
            for j in range(i + 1, len(lines)):
                if lines[j].rstrip("\n").startswith(closing) and \
                        (len(lines[j].rstrip("\n")) == len(closing) or lines[j][len(closing)] in " ;/)"):
                    found.append((function_name(lines, i), i + 1, j - i + 1))
                    i = j
                    break
        i += 1
    return found


def check(root):
    problems = []
    for path in sources(root):
        rel = os.path.relpath(path, root)
        with open(path, encoding="utf-8", errors="replace") as f:
            lines = f.readlines()
        if len(lines) > MAX_FILE_LINES and not any(ONE_JOB.match(l) for l in header_comment(lines)):
            problems.append(f"{rel}: {len(lines)} lines > {MAX_FILE_LINES} and no 'One job:' in its header comment")
        for name, first, length in functions(lines):
            if length > MAX_FUNCTION_LINES:
                problems.append(f"{rel}:{first}: function {name} has {length} lines > {MAX_FUNCTION_LINES}")
    return problems


def self_test():
    failures = []
    with tempfile.TemporaryDirectory() as tmp:
        os.makedirs(os.path.join(tmp, "src"))
        body = "".join(f"  x += {k};\n" for k in range(MAX_FUNCTION_LINES))
        with open(os.path.join(tmp, "src", "long_function.cpp"), "w") as f:
            f.write("// A test file.\nint LongFunction(int x) {\n" + body + "  return x;\n}\n")
        with open(os.path.join(tmp, "src", "long_file.cpp"), "w") as f:
            f.write("// A test file.\n" + "".join(f"int v{k} = {k};\n" for k in range(MAX_FILE_LINES + 1)))
        with open(os.path.join(tmp, "src", "one_job.cpp"), "w") as f:
            f.write("// A test file. One job: a table.\n" + "".join(f"int w{k} = {k};\n" for k in range(MAX_FILE_LINES + 1)))
        caught = check(tmp)
        if not any("LongFunction" in c for c in caught):
            failures.append("self-test: a function of 152 lines was not reported")
        if not any(c.startswith("src/long_file.cpp") for c in caught):
            failures.append("self-test: a file of 602 lines was not reported")
        if any(c.startswith("src/one_job.cpp") for c in caught):
            failures.append("self-test: a long file with 'One job:' was reported")
    return failures


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--root", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
    parser.add_argument("--self-test", action="store_true")
    args = parser.parse_args()
    problems = check(os.path.abspath(args.root))
    if args.self_test:
        problems += self_test()
    for p in problems:
        print(p, file=sys.stderr)
    if problems:
        print(f"check_sizes: {len(problems)} problem(s)", file=sys.stderr)
        return 1
    print(f"check_sizes: no file above {MAX_FILE_LINES} lines without a stated job, no function above "
          f"{MAX_FUNCTION_LINES} lines")
    return 0


if __name__ == "__main__":
    sys.exit(main())
