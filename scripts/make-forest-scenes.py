#!/usr/bin/env python3
"""Writes assets/scenes/bench/forest-{10k,100k,1m,10m}.toml and their density maps: one
generator (the built-in scene's procedural hills, the same three maps stretched over each
terrain, 1,000 trees per hectare on average), four world sizes (10 ha to 100 km²). Run from the
repository root; deterministic."""
import math, struct, zlib, pathlib

N = 128
OUT = pathlib.Path("assets/scenes/bench")

def value_noise(seed, x, y):
    def h(i, j):
        v = (i * 374761393 + j * 668265263 + seed * 2246822519) & 0xFFFFFFFF
        v = ((v ^ (v >> 13)) * 1274126177) & 0xFFFFFFFF
        return ((v ^ (v >> 16)) & 0xFFFF) / 65535.0
    i, j = math.floor(x), math.floor(y)
    fx, fy = x - i, y - j
    sx, sy = fx * fx * (3 - 2 * fx), fy * fy * (3 - 2 * fy)
    a = h(i, j) + (h(i + 1, j) - h(i, j)) * sx
    b = h(i, j + 1) + (h(i + 1, j + 1) - h(i, j + 1)) * sx
    return a + (b - a) * sy

def fbm(seed, x, y):
    return sum(value_noise(seed + o, x * 2 ** o, y * 2 ** o) / 2 ** o for o in range(4)) / 1.875

def smooth(e0, e1, v):
    t = min(max((v - e0) / (e1 - e0), 0.0), 1.0)
    return t * t * (3 - 2 * t)

def png(path, values):
    raw = b"".join(b"\x00" + bytes(int(round(v * 255)) for v in row) for row in values)
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)
    data = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", N, N, 8, 0, 0, 0, 0))
    data += chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")
    path.write_bytes(data)

# Stands of pine and of prunus with clearings between; bushes everywhere but thinner under pines.
stand = [[fbm(11, 6 * c / N, 6 * r / N) for c in range(N)] for r in range(N)]
clear = [[fbm(23, 9 * c / N, 9 * r / N) for c in range(N)] for r in range(N)]
pine = [[smooth(0.45, 0.6, stand[r][c]) * smooth(0.25, 0.4, clear[r][c]) for c in range(N)] for r in range(N)]
prunus = [[smooth(0.55, 0.4, stand[r][c]) * smooth(0.25, 0.4, clear[r][c]) for c in range(N)] for r in range(N)]
bush = [[0.35 + 0.65 * smooth(0.2, 0.5, clear[r][c]) * (1 - 0.5 * pine[r][c]) for c in range(N)] for r in range(N)]
means = {}
for name, m in [("pine", pine), ("prunus", prunus), ("bush", bush)]:
    q = [[round(v * 255) / 255 for v in row] for row in m]
    means[name] = sum(map(sum, q)) / (N * N)
    png(OUT / "maps" / f"forest-{name}.png", m)

target = {"pine": 250.0, "prunus": 150.0, "bush": 600.0}  # trees / ha, mean
heights = {"pine": (12, 20), "prunus": (5, 9), "bush": (0.8, 2.2)}
for label, side, relief, distance in [
    ("10k", 316.2, 40, None),
    ("100k", 1000.0, 80, None),
    ("1m", 3162.3, 150, 2000),
    ("10m", 10000.0, 300, 2000),
]:
    lines = [
        f"# Benchmark world ({label} trees): {side / 1000:g} km square of procedural hills, pine,",
        "# prunus and bush from density maps (1,000 trees/ha on average), tiled placement: trees are",
        "# produced tile by tile as they come within range. Made by scripts/make-forest-scenes.py.",
        "",
        "[terrain]",
        f"procedural = {{ seed = 7, size_m = {side:g}, relief_m = {relief} }}",
        "",
    ]
    for name in ["pine", "prunus", "bush"]:
        peak = target[name] / means[name]
        lo, hi = heights[name]
        lines += [
            "[[species]]",
            f'name = "{name}"',
            f'preset = "{name}"',
            f'density_map = "maps/forest-{name}.png"',
            f"density_per_ha = {peak:.2f}",
            f"height_m = [{lo:g}, {hi:g}]",
            "",
        ]
    lines += ["[placement]", 'method = "tiled"', "seed = 2024", "", "[world]", "tile_m = 256"]
    if distance:
        lines.append(f"tree_distance_m = {distance}")
    (OUT / f"forest-{label}.toml").write_text("\n".join(lines) + "\n")
print({k: round(v, 3) for k, v in means.items()})
