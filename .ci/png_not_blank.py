#!/usr/bin/env python3
"""Checks that a PNG (8-bit RGB or RGBA, not interlaced) is not blank: at least MIN_SHARE of its
pixels differ from its most common colour. Usage: png_not_blank.py FILE [MIN_SHARE]"""
import struct, sys, zlib
from collections import Counter

def pixels(path):
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", "not a PNG"
    pos, idat, w = 8, b"", None
    while pos < len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            w, h, depth, colour, _, _, interlace = struct.unpack(">IIBBBBB", body)
            assert depth == 8 and colour in (2, 6) and interlace == 0, "8-bit RGB(A) only"
            bpp = 3 if colour == 2 else 4
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    raw, stride, prev, rows = zlib.decompress(idat), w * bpp, bytearray(w * bpp), []
    for y in range(h):
        f, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - bpp] if i >= bpp else 0
            b, c = prev[i], prev[i - bpp] if i >= bpp else 0
            p = a + b - c
            pred = [0, a, b, (a + b) // 2, a if abs(p - a) <= abs(p - b) and abs(p - a) <= abs(p - c) else (b if abs(p - b) <= abs(p - c) else c)][f]
            line[i] = (line[i] + pred) & 0xFF
        rows.append(line)
        prev = line
    return [tuple(r[i:i + 3]) for r in rows for i in range(0, stride, bpp)], w, h

if __name__ == "__main__":
    px, w, h = pixels(sys.argv[1])
    share = float(sys.argv[2]) if len(sys.argv) > 2 else 0.05
    common, n = Counter(px).most_common(1)[0]
    other = 1 - n / len(px)
    print(f"{sys.argv[1]}: {w}x{h}, {other:.3f} of the pixels differ from the background {common}")
    sys.exit(0 if other >= share else 1)
