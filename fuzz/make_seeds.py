#!/usr/bin/env python3
"""Writes the fuzz seed corpora under fuzz/seeds/<target>/ from the repository's assets and test
data plus a few tiny synthetic files (stdlib only). Run from anywhere; scripts/fuzz.sh runs it."""
import base64, json, os, shutil, struct, zlib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SEEDS = ROOT / "fuzz" / "seeds"
BAD = ROOT / "crates" / "sylvan" / "tests" / "data" / "bad"


def put(target, name, data):
    d = SEEDS / target
    d.mkdir(parents=True, exist_ok=True)
    (d / name).write_bytes(data if isinstance(data, bytes) else data.encode())


def copy(target, paths):
    for p in paths:
        put(target, p.name, p.read_bytes())


def png_gray(w, h, depth, px):
    raw = b""
    for y in range(h):
        row = b"\0"
        for x in range(w):
            v = px(x, y)
            row += struct.pack(">H", v) if depth == 16 else bytes([v & 255])
        raw += row
    chunk = lambda t, d: struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d))
    ihdr = struct.pack(">IIBBBBB", w, h, depth, 0, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")


def tiff_gray(w, h, fmt, bits, sample_format, px):
    """Little-endian baseline TIFF, one strip, one band."""
    data = b"".join(struct.pack("<" + fmt, px(x, y)) for y in range(h) for x in range(w))
    entries = [
        (256, 3, 1, w), (257, 3, 1, h), (258, 3, 1, bits), (259, 3, 1, 1), (262, 3, 1, 1),
        (273, 4, 1, 8), (277, 3, 1, 1), (278, 3, 1, h), (279, 4, 1, len(data)),
        (339, 3, 1, sample_format),
    ]
    ifd_at = 8 + len(data)
    out = b"II*\0" + struct.pack("<I", ifd_at) + data
    out += struct.pack("<H", len(entries))
    for tag, typ, n, v in entries:
        out += struct.pack("<HHI", tag, typ, n) + (struct.pack("<HH", v, 0) if typ == 3 else struct.pack("<I", v))
    return out + struct.pack("<I", 0)


def gltf_triangle(leaf, glb):
    pos = struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0)
    nrm = struct.pack("<9f", 0, 0, 1, 0, 0, 1, 0, 0, 1)
    uv = struct.pack("<6f", 0, 0, 1, 0, 0, 1)
    idx = struct.pack("<3H", 0, 1, 2) + b"\0\0"
    blob = pos + nrm + uv + idx
    doc = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"children": [1], "translation": [0, 1, 0]}, {"mesh": 0, "scale": [2, 2, 2]}],
        "meshes": [{"name": "trunk", "primitives": [{
            "attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3, "material": 0}]}],
        "materials": [{"name": "leaves" if leaf else "bark", "alphaMode": "MASK" if leaf else "OPAQUE",
                       "pbrMetallicRoughness": {"baseColorFactor": [0.4, 0.3, 0.2, 1]}}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 0, "byteOffset": 36, "componentType": 5126, "count": 3, "type": "VEC3"},
            {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC2"},
            {"bufferView": 2, "componentType": 5123, "count": 3, "type": "SCALAR"},
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 72},
            {"buffer": 0, "byteOffset": 72, "byteLength": 24},
            {"buffer": 0, "byteOffset": 96, "byteLength": 6},
        ],
        "buffers": [{"byteLength": len(blob)}],
    }
    if not glb:
        doc["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(blob).decode()
        return json.dumps(doc).encode()
    js = json.dumps(doc).encode()
    js += b" " * (-len(js) % 4)
    body = struct.pack("<I4s", len(js), b"JSON") + js + struct.pack("<I4s", len(blob), b"BIN\0") + blob
    return struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body


def main():
    if SEEDS.exists():
        shutil.rmtree(SEEDS)
    copy("lsystem", sorted((ROOT / "assets" / "plants").glob("*.lsys")))
    scenes = sorted((ROOT / "assets" / "scenes").rglob("*.toml")) + sorted(BAD.glob("scene_*.toml"))
    copy("scene", scenes)
    put("scene", "camera_path.toml",
        'interpolation = "catmull-rom"\nfov_deg = 50\n\n[[key]]\nt = 0\nposition = [0, 10, 0]\n'
        'look_at = [0, 0, 100]\n\n[[key]]\nt = 2\nposition = [20, 10, 0]\nlook_at = [20, 0, 100]\nfov_deg = 45\n')
    copy("positions_csv", sorted((ROOT / "assets" / "scenes").rglob("*.csv")) + sorted(BAD.glob("*.csv")))
    put("positions_csv", "quoted.csv", 'x,y,species,height_m,yaw_deg\n"1.5",2,pine,12,30\n3,4,,,\n')
    put("heightmap", "gray16_8x8.png", png_gray(8, 8, 16, lambda x, y: x * 4000 + y * 300))
    put("heightmap", "gray8_4x4.png", png_gray(4, 4, 8, lambda x, y: x * 60 + y))
    put("heightmap", "u16_4x4.tif", tiff_gray(4, 4, "H", 16, 1, lambda x, y: x * 1000 + y))
    put("heightmap", "i16_4x4.tif", tiff_gray(4, 4, "h", 16, 2, lambda x, y: x * 100 - 200))
    put("heightmap", "f32_4x4.tif", tiff_gray(4, 4, "f", 32, 3, lambda x, y: x * 1.5 + y))
    copy("heightmap", sorted(BAD.glob("*.tif")) + sorted(BAD.glob("*.png")))
    put("gltf", "triangle.glb", gltf_triangle(False, True))
    put("gltf", "leaf.gltf", gltf_triangle(True, False))
    copy("gltf", sorted(BAD.glob("gltf_*")))
    data = ROOT / "crates" / "sylvan-plant" / "tests" / "data"
    copy("obj", [data / "sapling.obj"] + sorted(BAD.glob("obj_*")))
    put("obj", "quad.obj", "mtllib quad.mtl\no leaves\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n"
        "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\nusemtl Leaf\nf 1/1/1 2/2/1 3/3/1 4/4/1\n"
        "o trunk\nv 0 -1 0\nf 1 2 5\nf -1 -2 -3\n")


if __name__ == "__main__":
    main()
