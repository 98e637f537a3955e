#!/usr/bin/env python3
"""The deepest static call path of a Cortex-M ELF and its stack use.

    python3 scripts/stack-depth.py ELF [ROOT]

Disassembles ELF with the toolchain's llvm-objdump (`rustup component add
llvm-tools`), takes each function's frame from its prologue (`push` of
registers, `sub sp, #n`, and the `ldr rX, =-n; add sp, rX` of large frames)
and its callees from `bl` and tail `b` to other functions, and prints the
deepest path from ROOT (a substring of a symbol; default
`__cortex_m_rt_main`) with each frame. Calls through pointers and
exception handlers are not seen, so this is a bound from below of what the
painted stack (`host-sim hil`, `host-sim drive`) measures; where the two
agree, the path printed is where the peak is. Recursion is cut at the
first repeat.
"""
import functools
import glob
import os
import re
import subprocess
import sys


def objdump():
    sysroot = subprocess.run(["rustc", "--print", "sysroot"], capture_output=True, text=True, check=True).stdout.strip()
    found = glob.glob(os.path.join(sysroot, "lib/rustlib/*/bin/llvm-objdump"))
    if not found:
        sys.exit("llvm-objdump not found: rustup component add llvm-tools")
    return found[0]


def pushed(vfp, regs):
    """Bytes a `push`/`vpush` of the register list `regs` takes (`r4, lr`,
    `d8-d15`)."""
    total = 0
    for r in regs.replace(" ", "").split(","):
        lo, _, hi = r.partition("-")
        width = 8 if lo.startswith("d") else 4
        count = int(hi[1:]) - int(lo[1:]) + 1 if hi else 1
        total += width * count if vfp else 4 * count
    return total


def demangle(name):
    """A legacy Rust symbol (`_ZN` + length-prefixed parts + hash) as
    `a::b::c`, with `$LT$`-style escapes undone; others as they are."""
    if not name.startswith("_ZN"):
        return name
    parts, i = [], 3
    while i < len(name) and name[i].isdigit():
        j = i
        while name[j].isdigit():
            j += 1
        n = int(name[i:j])
        parts.append(name[j : j + n])
        i = j + n
    if parts and re.fullmatch(r"h[0-9a-f]{16}", parts[-1]):
        parts.pop()
    out = "::".join(parts)
    for a, b in [("$LT$", "<"), ("$GT$", ">"), ("$u20$", " "), ("$C$", ","), ("$RF$", "&"), ("$u7b$", "{"), ("$u7d$", "}"), ("..", "::"), ("$BP$", "*")]:
        out = out.replace(a, b)
    return out[1:] if out.startswith("_<") else out


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    elf = sys.argv[1]
    root = sys.argv[2] if len(sys.argv) > 2 else "__cortex_m_rt_main"
    text = subprocess.run([objdump(), "-d", "--no-show-raw-insn", elf], capture_output=True, text=True, check=True).stdout
    lines = text.split("\n")
    # Literal-pool words, for the large frames loaded from them.
    words = {}
    for line in lines:
        m = re.match(r"\s*([0-9a-f]+):\s+(?:[0-9a-f]{2} ){0,4}\s*\.word\s+0x([0-9a-f]+)", line)
        if m:
            words[int(m.group(1), 16)] = int(m.group(2), 16)
    fns, cur = {}, None
    for i, line in enumerate(lines):
        m = re.match(r"^[0-9a-f]+ <(.*)>:$", line)
        if m:
            cur = m.group(1)
            fns[cur] = {"frame": 0, "calls": set()}
            continue
        if cur is None:
            continue
        f = fns[cur]
        m = re.search(r"\t(v?)push(?:\.w)?\t\{([^}]*)\}", line)
        if m:
            f["frame"] += pushed(m.group(1) == "v", m.group(2))
        m = re.search(r"\tsub[w.]?w?\tsp, (?:sp, )?#(0x[0-9a-f]+|\d+)", line)
        if m:
            f["frame"] += int(m.group(1), 0)
        m = re.search(r"\tadd\tsp, (r\d+)", line)
        if m:
            reg = m.group(1)
            for j in range(i - 1, max(i - 12, 0), -1):
                mm = re.search(r"\tldr(?:\.w)?\t" + reg + r", \[pc, #0x[0-9a-f]+\]\s+@ 0x([0-9a-f]+)", lines[j])
                if mm:
                    v = words.get(int(mm.group(1), 16))
                    if v is not None and v >= 1 << 31:
                        f["frame"] += (1 << 32) - v
                    break
        m = re.search(r"\tbl\t0x[0-9a-f]+ <([^>+]*)>", line)
        if m:
            f["calls"].add(m.group(1))
        m = re.search(r"\tb(?:\.w)?\t0x[0-9a-f]+ <([^>+]*)>", line)
        if m and m.group(1) != cur:
            f["calls"].add(m.group(1))
    sys.setrecursionlimit(100000)

    @functools.lru_cache(maxsize=None)
    def deepest(fn, seen=frozenset()):
        if fn in seen or fn not in fns:
            return 0, ()
        best = (0, ())
        for c in fns[fn]["calls"]:
            d = deepest(c, seen | {fn})
            if d[0] > best[0]:
                best = d
        return fns[fn]["frame"] + best[0], ((fns[fn]["frame"], fn),) + best[1]

    roots = [k for k in fns if root in k]
    if not roots:
        sys.exit(f"no symbol contains {root!r}")
    total, path = deepest(roots[0])
    print(f"{total} B on the deepest static path from {roots[0]}:")
    for frame, name in path:
        print(f"{frame:6} {demangle(name)}")


main()
