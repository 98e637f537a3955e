#!/usr/bin/env python3
"""Instructions by function in a QEMU block trace, within the calls of one
function: where a driven camera's plan goes (README, "The closed loop").

QEMU logs each translated block (`-d in_asm`: its instructions) and each
execution of one (`-d exec,nochain`: "Trace ... [.../PC/...] SYMBOL"), so
the instructions a block runs are counted for the symbol QEMU names. A
window starts where FUNCTION is entered from outside it and ends when the
caller runs again; inside it, a library routine's instructions
(compiler-builtins, `__aeabi_*`, libm) are counted for the function that
called it. Without `-icount` (which would log rewound blocks twice).

Usage:
  # a wrapper earlier in PATH adds the flags to every QEMU that host-sim starts:
  mkdir -p /tmp/qw && printf '#!/bin/sh\\nexec /usr/bin/qemu-system-arm "$@" -d in_asm,exec,nochain -D /tmp/qlog.txt\\n' > /tmp/qw/qemu-system-arm && chmod +x /tmp/qw/qemu-system-arm
  PATH=/tmp/qw:$PATH host-sim drive --board lm3s6965evb --frames 2 --batched --out DIR
  python3 scripts/qemu-trace.py /tmp/qlog.txt planner4plan [WINDOW]

FUNCTION is a fragment of the mangled name (`planner4plan` for
`hilcam::planner::plan`); WINDOW picks one call (default: the last).
"""
import re
import subprocess
import sys
from collections import Counter

TRACE = re.compile(r"\[[0-9a-f]+/([0-9a-f]+)/")


def blocks(path):
    """(symbol, instructions) for every block executed, in order."""
    size = {}
    start, n = None, 0
    with open(path, errors="replace") as f:
        for line in f:
            if line.startswith("IN:"):
                start, n = None, 0
            elif line.startswith("0x") and ":" in line[:12]:
                if start is None:
                    start = int(line[:10], 16)
                n += 1
            elif line.startswith("Trace"):
                if start is not None:
                    size[start] = n
                    start = None
                m = TRACE.search(line)
                if m:
                    pc = int(m.group(1), 16)
                    yield line.rsplit("] ", 1)[-1].strip(), size.get(pc, 0)


def library(sym):
    return "compiler_builtins" in sym or sym.startswith("__aeabi") or "libm" in sym or sym in ("fmax", "fmin")


def demangle(sym):
    try:
        return subprocess.run(["c++filt"], input=sym, capture_output=True, text=True).stdout.strip()
    except OSError:
        return sym


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    path, function = sys.argv[1], sys.argv[2]
    seq = list(blocks(path))
    windows = []
    i = 1
    while i < len(seq):
        if function in seq[i][0] and function not in seq[i - 1][0]:
            caller, counts, last, j = seq[i - 1][0], Counter(), None, i
            while j < len(seq) and seq[j][0] != caller:
                sym, n = seq[j]
                if not library(sym):
                    last = sym
                counts[last if library(sym) else sym] += n
                j += 1
            windows.append((demangle(caller), counts))
            i = j
        else:
            i += 1
    if not windows:
        sys.exit(f"no call of {function} in {path}")
    for k, (caller, counts) in enumerate(windows):
        print(f"call {k} from {caller}: {sum(counts.values())} instructions")
    pick = int(sys.argv[3]) if len(sys.argv) > 3 else len(windows) - 1
    caller, counts = windows[pick]
    print(f"\ncall {pick}, by function (library routines counted for their caller):")
    for sym, n in counts.most_common(25):
        print(f"{n:>10}  {demangle(sym)}")


if __name__ == "__main__":
    main()
