#!/usr/bin/env python3
"""How many pixels differ between two 8-bit gray PNG frames.

    python3 scripts/frame-diff.py A.png B.png

Reads the `frame.png` that `host-sim render` and `host-sim frame` write for
a Gray8 scene (8-bit grayscale, non-interlaced; the standard library only:
zlib and the five PNG row filters) and prints the count of pixels whose
values differ, and the frame's size. docs/bench/README.md counts the pixels
the standard scene's spheres cover this way: the bytes that differ from the
frame without them.
"""
import struct
import sys
import zlib


def gray8(path):
    """The rows of an 8-bit gray PNG as lists of ints."""
    data = open(path, "rb").read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        sys.exit(f"{path}: not a PNG")
    pos, idat, width, height = 8, b"", 0, 0
    while pos < len(data):
        (n,) = struct.unpack(">I", data[pos : pos + 4])
        kind, body = data[pos + 4 : pos + 8], data[pos + 8 : pos + 8 + n]
        pos += 12 + n
        if kind == b"IHDR":
            width, height, depth, colour, _, _, interlace = struct.unpack(">IIBBBBB", body)
            if (depth, colour, interlace) != (8, 0, 0):
                sys.exit(f"{path}: not 8-bit gray non-interlaced (depth {depth}, colour type {colour})")
        elif kind == b"IDAT":
            idat += body
    raw = zlib.decompress(idat)
    rows, prev, i = [], [0] * width, 0
    for _ in range(height):
        kind, row = raw[i], list(raw[i + 1 : i + 1 + width])
        i += 1 + width
        for x in range(width):
            a = row[x - 1] if x else 0
            b = prev[x]
            c = prev[x - 1] if x else 0
            if kind == 1:
                row[x] = (row[x] + a) & 255
            elif kind == 2:
                row[x] = (row[x] + b) & 255
            elif kind == 3:
                row[x] = (row[x] + (a + b) // 2) & 255
            elif kind == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                row[x] = (row[x] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(row)
        prev = row
    return rows


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    a, b = gray8(sys.argv[1]), gray8(sys.argv[2])
    if len(a) != len(b) or len(a[0]) != len(b[0]):
        sys.exit("the frames differ in size")
    differ = sum(p != q for ra, rb in zip(a, b) for p, q in zip(ra, rb))
    print(f"{differ} of {len(a) * len(a[0])} pixels differ")


if __name__ == "__main__":
    main()
