#!/usr/bin/env python3
"""Leaf-mask agreement of renders: `mask-iou.py BACKGROUND REFERENCE IMG [X,Y,W,H]` prints the
IoU of the pixels that differ from BACKGROUND (the same view without trees) by more than 12
levels in some channel, IMG's mask against REFERENCE's, and IMG's coverage / REFERENCE's.
Reads 8-bit RGB/RGBA PNGs as `sylvan render` writes them (no dependencies)."""
import struct, sys, zlib


def read(path):
    data = open(path, "rb").read()
    i, idat, w, h, ct = 8, b"", 0, 0, 6
    while i < len(data):
        (n,) = struct.unpack(">I", data[i:i + 4])
        kind, body = data[i + 4:i + 8], data[i + 8:i + 8 + n]
        i += 12 + n
        if kind == b"IHDR":
            w, h, _, ct = struct.unpack(">IIBB", body[:10])
        elif kind == b"IDAT":
            idat += body
    bpp = {6: 4, 2: 3}[ct]
    raw, rows, prev, k = zlib.decompress(idat), [], bytearray(w * bpp), 0
    for _ in range(h):
        f, line = raw[k], bytearray(raw[k + 1:k + 1 + w * bpp])
        k += 1 + w * bpp
        for x in range(len(line)):
            a = line[x - bpp] if x >= bpp else 0
            b = prev[x]
            c = prev[x - bpp] if x >= bpp else 0
            if f == 1:
                line[x] = (line[x] + a) & 255
            elif f == 2:
                line[x] = (line[x] + b) & 255
            elif f == 3:
                line[x] = (line[x] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[x] = (line[x] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(line)
        prev = line
    return w, h, bpp, rows


def mask(img, bg, box):
    w, h, bpp, rows = img
    _, _, bbpp, brows = bg
    x0, y0, cw, ch = box or (0, 0, w, h)
    return [
        any(abs(rows[y][x * bpp + c] - brows[y][x * bbpp + c]) > 12 for c in range(3))
        for y in range(y0, y0 + ch)
        for x in range(x0, x0 + cw)
    ]


bg, ref, img = (read(p) for p in sys.argv[1:4])
box = tuple(int(v) for v in sys.argv[4].split(",")) if len(sys.argv) > 4 else None
mr, mi = mask(ref, bg, box), mask(img, bg, box)
inter = sum(a and b for a, b in zip(mr, mi))
union = sum(a or b for a, b in zip(mr, mi))
print(f"{inter / max(union, 1):.3f} {sum(mi) / max(sum(mr), 1):.3f}")
