#!/usr/bin/env python3
"""Extracts the `///` doc comments of the public headers into a C++ table for the bindings (issue 21).

Usage: gen_cpp_docs.py OUT.inc HEADER...   (run by CMake at build time; python/CMakeLists.txt)

Each entry is {"Key", "header", R"(text)"}: Key is a declaration's name (`SolveFilterDare`,
`DareSolution`) or, inside a struct or class, `Struct::member` (`DareSolution::P_pred`); the comment is
the `///` block above the declaration or the `///<` comment after it (a data member without one,
right below a documented member, shares that member's block; a function without one, right below a
documented result struct, shares the struct's). Overloads of one name are joined.
python/src/cpp_docs.cpp appends these texts to the docstrings of the bindings that wrap the
declarations, so the Python docstrings carry the C++ comments and cannot drift from them.
"""
import os
import re
import sys

IDENT = re.compile(r"[A-Za-z_]\w*")


def code_part(line):
    """The line without its // comment (string literals in declarations are rare and short)."""
    i = line.find("//")
    return line if i < 0 else line[:i]


def declared_name(decl):
    """The name a declaration introduces: struct/class/enum name, function name, or member name."""
    decl = re.sub(r"\s+", " ", decl).strip()
    m = re.match(r"(?:template ?<[^>]*> ?)?(?:struct|class|enum class|enum) (\w+)", decl)
    if m:
        return m.group(1)
    if decl.startswith(("using ", "namespace ", "#", "friend ", "static_assert")):
        return None
    before_init = decl.split("=")[0] if "operator" not in decl else decl
    if "(" in before_init:
        head = decl[: decl.index("(")].strip()
        if head.endswith("operator"):
            return None
        names = IDENT.findall(head)
        return names[-1] if names else None
    head = decl.split("=")[0].split("{")[0].rstrip(" ;,")
    names = IDENT.findall(head)
    return names[-1] if names else None


def member_names(decl):
    """The names of a data member declaration that declares several (`Eigen::MatrixXd F, H, V;`)."""
    if "(" in decl.split("=")[0] or "," not in decl or "<" in decl.split(",")[0] and ">" not in decl.split(",")[0]:
        return None
    parts = [p.split("=")[0].strip(" ;") for p in decl.split(";")[0].split(",")]
    first = IDENT.findall(parts[0])
    names = [first[-1]] + [p for p in parts[1:] if IDENT.fullmatch(p)]
    return names if len(names) == len(parts) else None


def extract(path):
    """(key, text) for every documented declaration of one header."""
    entries, pending, group, scopes, depth = [], [], [], [], 0
    struct_doc, last_struct_doc = {}, []  # a result struct's comment also documents the function right below
    lines = open(path, encoding="utf-8").read().splitlines()
    i = 0
    while i < len(lines):
        stripped = lines[i].strip()
        if stripped.startswith("///") and not stripped.startswith("///<"):
            if not pending:
                group = []
            pending.append(stripped[3:].strip())
            i += 1
            continue
        if not stripped or stripped.startswith("//"):
            if not stripped:
                pending, group, last_struct_doc = [], [], []
            i += 1
            continue
        # A declaration: gather lines until it ends (';' or '{' or ')' + ';').
        decl_lines = [lines[i]]
        while not re.search(r"[;{}]\s*(//.*)?$", decl_lines[-1]) and i + 1 < len(lines):
            i += 1
            decl_lines.append(lines[i])
        decl = " ".join(code_part(l) for l in decl_lines)
        trailing = [l.split("///<", 1)[1].strip() for l in decl_lines if "///<" in l]
        name = declared_name(decl)
        scope = "::".join(s for s, _ in scopes)
        if not pending and not trailing and not scopes and last_struct_doc and "(" in decl.split("=")[0]:
            pending = last_struct_doc
        last_struct_doc = []
        if pending:
            group = pending
        elif not trailing and scopes and "(" not in decl.split("=")[0]:
            pending = group  # a data member right below a documented one shares its comment
        text = "\n".join(pending + trailing)
        if name and (pending or trailing) and not re.match(r"\s*k[A-Z]\w*\s*[,=]", decl):
            names = member_names(decl) or [name]
            if len(names) > 1:
                text = ", ".join(names) + ": " + text
            for each in names:
                entries.append((f"{scope}::{each}" if scope else each, text))
        pending = []
        m = re.match(r"\s*(?:template ?<[^>]*> ?)?(struct|class) (\w+)[^;]*\{", decl)
        opened = decl.count("{") - decl.count("}")
        if m and opened > 0:
            scopes.append((m.group(2), depth))
            struct_doc[m.group(2)] = text
        depth += opened
        while scopes and depth <= scopes[-1][1]:
            closed = scopes.pop()[0]
            if not scopes and struct_doc.get(closed):
                last_struct_doc = struct_doc[closed].split("\n")
        i += 1
    return entries


def pythonic(text):
    """Doxygen tags and C++ names as a Python reader sees them."""
    text = re.sub(r"@param (\w+)", r"\1:", text)
    text = re.sub(r"@throws\s+", "Raises ", text)
    text = re.sub(r"@return\s+", "Returns ", text)
    return text.replace("kfx::NumericalError", "kfx.NumericalError").replace("kfx::Error", "kfx.Error")


def main(out, headers):
    table = {}
    for header in sorted(headers):
        rel = "include/kfx/" + os.path.basename(header)
        for key, text in extract(header):
            text = pythonic(text)
            if key.startswith("kfx::"):
                key = key[5:]
            if key in table and text not in table[key][1]:
                table[key] = (table[key][0], table[key][1] + "\n\n" + text)
            elif key not in table:
                table[key] = (rel, text)
    body = ["// Generated by python/gen_cpp_docs.py from the doc comments of include/kfx/*.hpp. Do not edit."]
    for key, (rel, text) in sorted(table.items()):
        assert ")kfxdoc\"" not in text
        body.append(f'{{"{key}", "{rel}", R"kfxdoc({text})kfxdoc"}},')
    text = "\n".join(body) + "\n"
    if not os.path.exists(out) or open(out, encoding="utf-8").read() != text:
        with open(out, "w", encoding="utf-8") as f:
            f.write(text)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2:])
