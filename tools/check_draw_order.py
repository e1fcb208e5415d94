#!/usr/bin/env python3
"""One random draw per statement in the tests (tests/support/matrix_testing.hpp, TestRng).

C++ leaves the order in which function arguments and the operands of most operators are evaluated
unspecified: GCC evaluates arguments right to left, Clang left to right. A statement with two draws from
one generator, e.g. `Model(rng.Gaussian(n, n), rng.Spd(n))` or `rng.Spd(n) + rng.Spd(n)`, therefore
builds a different system under each compiler, and a seeded test tests two systems
(docs/robustness.md, "Sanitizer findings"). This check fails on any such statement.

  check_draw_order.py --root DIR               report every statement with two or more draws; exit 1 if any
  check_draw_order.py --root DIR --self-test   also check the rule on small snippets

Generators are the objects declared (as variables or parameters) with one of GENERATOR_TYPES. A draw
from a generator g is a member call `g.F(...)` / `g->F(...)`, a call `g(...)`, or g passed to a
function, `F(..., g, ...)` (TestRng helpers such as `RandomStep(rng, ...)` and `dist(gen)`). A statement
is the text between two `;`, `{` or `}` outside parentheses and brackets, comments and literals removed.
Braced initializer lists are evaluated in order, but they are counted like the rest: one draw per
statement is the rule, with no exceptions to remember.
"""
import argparse
import os
import re
import sys

CHECKED_DIRS = ("tests",)
SUFFIXES = (".cpp", ".hpp", ".h", ".cc")
GENERATOR_TYPES = (
    r"(?:kfx::)?(?:testing::)?TestRng",
    r"std::mt19937(?:_64)?",
    r"std::default_random_engine",
    r"std::minstd_rand0?",
    r"std::ranlux\w+",
    r"(?:kfx::)?Rng",
)
DECLARATION = re.compile(r"\b(?:" + "|".join(GENERATOR_TYPES) + r")\b\s*[&*]?\s*([A-Za-z_]\w*)\s*[({=;,)]")


def strip(text):
    """Comments, string and character literals replaced by spaces (newlines kept for line numbers)."""
    out, i, n = [], 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(" " * (j - i))
            i = j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif c == "R" and text.startswith('R"', i):
            m = re.match(r'R"([^(]*)\(', text[i:])
            end = text.find(")" + m.group(1) + '"', i) if m else -1
            j = n if end < 0 else end + len(m.group(1)) + 2
            out.append(re.sub(r"[^\n]", " ", text[i:j]))
            i = j
        elif c in "\"'":
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            if c == "'" and i > 0 and text[i - 1].isalnum():  # digit separator 1'000
                out.append(c)
                i += 1
                continue
            out.append(" " * (min(j + 1, n) - i))
            i = j + 1
        else:
            out.append(c)
            i += 1
    return "".join(out)


def statements(code):
    """(first line, text) of each statement: split at ; { } outside ( ) and [ ]."""
    depth, start, line, start_line = 0, 0, 1, 1
    for i, c in enumerate(code):
        if c in "([":
            depth += 1
        elif c in ")]":
            depth = max(0, depth - 1)
        elif c in ";{}" and depth == 0:
            yield start_line, code[start:i]
            start, start_line = i + 1, line
        if c == "\n":
            line += 1
            if code[start:i + 1].strip() == "":
                start_line = line
    yield start_line, code[start:]


def draws(statement, name):
    g = re.escape(name)
    member = re.findall(r"(?<![\w.>])" + g + r"\s*(?:\.|->)\s*[A-Za-z_]\w*\s*\(", statement)
    call = re.findall(r"(?<![\w.>])" + g + r"\s*\(", statement)
    argument = re.findall(r"[(,]\s*" + g + r"\s*(?=[,)])", statement)
    return len(member) + len(call) + len(argument)


def check_text(text, path="<snippet>"):
    code = strip(text)
    names = set(DECLARATION.findall(code))
    problems = []
    for line, stmt in statements(code):
        for name in sorted(names):
            k = draws(stmt, name)  # a declaration `TestRng rng(3)` counts as one
            if k >= 2:
                shown = " ".join(stmt.split())
                problems.append(f"{path}:{line}: {k} draws from '{name}' in one statement "
                                f"(evaluation order is unspecified; draw in separate statements): {shown[:160]}")
    return problems


def sources(root):
    for top in CHECKED_DIRS:
        for dirpath, dirnames, filenames in os.walk(os.path.join(root, top)):
            dirnames.sort()
            for name in sorted(filenames):
                if name.endswith(SUFFIXES):
                    yield os.path.join(dirpath, name)


def check(root):
    problems = []
    for path in sources(root):
        with open(path, encoding="utf-8") as f:
            problems += check_text(f.read(), os.path.relpath(path, root))
    return problems


# (snippet, number of findings): the old patterns are caught, one draw per statement passes.
SELF_TEST_CASES = (
    ("TestRng rng(3);\nconst Model m(MakeStep(rng.Gaussian(2, 2), rng.Spd(2)), x0, rng.Spd(2));", 1),
    ("testing::TestRng rng(1);\nconst MatrixXd S = rng.Spd(3) + rng.Spd(3);", 1),
    ("void F(TestRng& r) {\n  Use(RandomStep(r, 3, 2), r.Spd(2));\n}", 1),
    ("std::mt19937_64 gen(7);\nstd::normal_distribution<double> d;\ndouble x = d(gen) - d(gen);", 1),
    ("std::mt19937 g(1);\nauto v = Vec{g(), g()};", 1),
    ("kfx::testing::TestRng rng(2);\nF(rng.Gaussian(2,\n  2),\n  // rng.Spd(2) in a comment\n  \"rng.Spd(2)\");", 0),
    ("TestRng rng(3);\nconst MatrixXd A = rng.Gaussian(2, 2);\nconst MatrixXd Q = rng.Spd(2);\n"
     "const Model m(MakeStep(A, Q), x0, P0);", 0),
    ("TestRng rng(3), other(4);\nUse(rng.Spd(2), other.Spd(2));", 0),
    ("TestRng rng(3);\nfor (int i = 0; i < 3; ++i) { a = rng.Spd(2); b = rng.Spd(2); }", 0),
    ("TestRng rng(5);\nconst CoupledStep s = RandomStep(rng, 3, 2, 1, 2);", 0),
    ("std::mt19937_64 gen(7);\nstd::uniform_int_distribution<int> d(0, 3);\nint k = d(gen);\nint rng = 1'000;", 0),
)


def self_test():
    problems = []
    for snippet, expected in SELF_TEST_CASES:
        got = check_text(snippet)
        if len(got) != expected:
            problems.append(f"self-test: expected {expected} finding(s), got {len(got)} for:\n{snippet}\n" +
                            "\n".join(got))
    return problems


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--root", required=True)
    parser.add_argument("--self-test", action="store_true")
    args = parser.parse_args()
    problems = check(args.root)
    if args.self_test:
        problems += self_test()
    for p in problems:
        print(p)
    if problems:
        print(f"{len(problems)} problem(s)", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
