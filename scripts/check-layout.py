#!/usr/bin/env python3
"""Checks the code's shape: no source file over 1 000 lines and no function
over 150 (tests aside), and no import circle between modules of the core
or of host-sim (a module's `use` of another through `crate::` or `super::`
paths; a module's own descendants are part of it). Exits 1 naming what is
over. `cargo modules dependencies` (the cargo-modules crate) draws the
same graph from the compiler's view; this is the quick check the test
command runs."""
import os
import re
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
MAX_FILE, MAX_FN = 1000, 150


def rust_files(root):
    for dp, _, fn in os.walk(root):
        for f in fn:
            if f.endswith(".rs"):
                yield os.path.join(dp, f)


def is_test(path):
    return os.path.basename(path) == "tests.rs" or "/tests/" in path


def functions(text):
    """(name, first line, lines) of every fn with a body."""
    out = []
    for m in re.finditer(r"^\s*(?:pub(?:\([^)]*\))?\s+)?(?:const\s+)?(?:unsafe\s+)?fn\s+(\w+)", text, re.M):
        j, semi = text.find("{", m.end()), text.find(";", m.end())
        if j < 0 or (0 <= semi < j):
            continue
        depth, k = 0, j
        while k < len(text):
            c = text[k]
            if c == "{":
                depth += 1
            elif c == "}":
                depth -= 1
                if depth == 0:
                    break
            elif c == '"':
                k += 1
                while k < len(text) and text[k] != '"':
                    k += 2 if text[k] == "\\" else 1
            elif text.startswith("//", k):
                k = text.find("\n", k)
            elif c == "'" and text[k + 2:k + 3] == "'":
                k += 2
            k += 1
        first = text.count("\n", 0, m.start()) + 1
        out.append((m.group(1), first, text.count("\n", 0, k) + 2 - first))
    return out


def test_spans(text):
    """Line ranges of inline `#[cfg(test)] mod tests { ... }` blocks."""
    spans = []
    for m in re.finditer(r"#\[cfg\(test\)\]\s*mod \w+\s*\{", text):
        depth, k = 0, m.end() - 1
        while k < len(text):
            depth += {"{": 1, "}": -1}.get(text[k], 0)
            if depth == 0:
                break
            k += 1
        spans.append((text.count("\n", 0, m.start()) + 1, text.count("\n", 0, k) + 1))
    return spans


def cycles(src):
    mods = {}
    for p in rust_files(src):
        rel = os.path.relpath(p, src)[:-3].split(os.sep)
        if rel[-1] in ("mod", "lib", "main"):
            rel = rel[:-1]
        if rel and rel[-1] == "tests":
            continue
        mods["::".join(rel)] = open(p).read()
    names = set(mods)

    def resolve(segs):
        for i in range(len(segs), 0, -1):
            m = "::".join(segs[:i])
            if m in names:
                return m
        return ""

    edges = {}
    for m, s in mods.items():
        s = re.sub(r"#\[cfg\(test\)\]\s*mod tests\s*\{.*", "", s, flags=re.S)
        s = "\n".join(line.split("//")[0] for line in s.split("\n"))
        cur = m.split("::") if m else []
        for mm in re.finditer(r"\b(crate|super)((?:::\w+)+)", s):
            segs = mm.group(2).split("::")[1:]
            if mm.group(1) == "crate":
                path = segs
            else:
                up = cur[:-1]
                while segs and segs[0] == "super":
                    up, segs = up[:-1], segs[1:]
                path = up + segs
            t = resolve(path)
            if t and t != m and not t.startswith(m + "::") and not m.startswith(t + "::"):
                edges.setdefault(m, set()).add(t)
    found, state = [], {}

    def visit(v, stack):
        state[v] = 1
        for w in sorted(edges.get(v, ())):
            if state.get(w) == 1:
                found.append(stack[stack.index(w):] + [w])
            elif w not in state:
                visit(w, stack + [w])
        state[v] = 2

    for v in sorted(names):
        if v not in state:
            visit(v, [v])
    return found


def main():
    bad = []
    for root in ("src", "host-sim/src", "firmware/src"):
        for p in rust_files(os.path.join(ROOT, root)):
            if is_test(p):
                continue
            text = open(p).read()
            rel = os.path.relpath(p, ROOT)
            spans = test_spans(text)
            code_lines = text.count("\n") - sum(b - a + 1 for a, b in spans)
            if code_lines > MAX_FILE:
                bad.append(f"{rel}: {code_lines} lines (at most {MAX_FILE})")
            for name, first, n in functions(text):
                if n > MAX_FN and not any(a <= first <= b for a, b in spans):
                    bad.append(f"{rel}:{first}: fn {name} is {n} lines (at most {MAX_FN})")
    for root in ("src", "host-sim/src"):
        for c in cycles(os.path.join(ROOT, root)):
            bad.append(f"{root}: import circle {' -> '.join(c)}")
    for b in bad:
        print(b)
    if bad:
        sys.exit(1)
    print("layout: no file over 1 000 lines, no function over 150, no import circle")


if __name__ == "__main__":
    main()
