#!/usr/bin/env bash
# Reproduces the billboard-cloud figures (GPSS07, issue #16):
#   1. bake time and size of the chestnut (sylvan bake --technique billboard-cloud --json);
#   2. one chestnut (14 m) at apparent heights 800/400/200/100 px, 900x900, fov 40: FLIP around
#      the tree vs geometry --spp 16 for geometry 1 spp, billboard-cloud, octahedral, boxtree, hbt;
#   3. a 60-frame dolly from 10 m to 1 km: consecutive-frame FLIP of geometry and billboard-cloud
#      (a spike at a cloud or shader-LOD switch would show as max / median);
#   4. assets/scenes/eval/broadleaf.toml: FLIP and bench of geometry, billboard-cloud, octahedral;
#   5. bench medians (3 frames after warm-up) of geometry, billboard-cloud and octahedral on
#      scenes of 1, 100 and 1000 chestnuts, same run, and GPU bytes.
# Usage: scripts/measure-bcloud.sh [OUT_DIR]   (default out/measure-bcloud)
#        PARTS="bench" scripts/measure-bcloud.sh   runs only some of: bake fidelity dolly broadleaf bench
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-out/measure-bcloud}
. scripts/common.sh
json() { python3 -c "import json,sys; d=json.load(sys.stdin); print($1)"; }
PARTS=${PARTS:-bake fidelity dolly broadleaf bench}
part() { [[ " $PARTS " == *" $1 "* ]]; }

if part bake; then
echo "## Chestnut bake (sylvan bake --preset chestnut --technique billboard-cloud --no-cache --json)"
$S bake --preset chestnut --technique billboard-cloud --no-cache --json > "$OUT/bake.json"
json "f\"{d['bake_ms']/1e3:.2f} s, {d['bytes']/1e6:.2f} MB, planes {d['planes']}, {d['list_entries']:,} list entries, {d['leaves']:,} leaves\"" < "$OUT/bake.json"
$S plant --preset chestnut --stats > "$OUT/plant.json"
echo
echo "## Memory per chestnut"
python3 - "$OUT" <<'PY'
import json, sys
out = sys.argv[1]
b, p = json.load(open(f"{out}/bake.json")), json.load(open(f"{out}/plant.json"))
h = p["bbox_max"][1] - p["bbox_min"][1]
area = b["plane_area"][0]
# A plain billboard cloud of the near cloud's planes, textured (colour + normal, RGBA8, mips)
# finely enough to show leaves as the 800 px close-up does: one texel per pixel there.
texel = h / 800
plain = area / texel**2 * 8 * 4 / 3
print("| representation | MB |")
print("|---|---|")
print(f"| billboard-cloud, all three clouds (planes, cells, lists, records, low-res tiles) | {b['bytes'] / 1e6:.2f} |")
print(f"| plain billboard cloud of the same {b['planes'][0]} planes at 1 texel per 800-px-view pixel ({area:.0f} m², estimate) | {plain / 1e6:.0f} |")
print(f"| polygonal leaves (44 B per vertex + 4 B per index) | {p['leaf_mesh_bytes'] / 1e6:.2f} |")
PY
fi

if part fidelity; then
echo
echo "## One chestnut (14 m), 900x900, fov 40: FLIP vs geometry --spp 16 around the tree (lower is better)"
echo "| height px | geometry 1 spp | billboard-cloud | octahedral | boxtree | hbt |"
echo "|---|---|---|---|---|---|"
SCENE=assets/scenes/eval/one-chestnut.toml
TECHS="billboard-cloud octahedral boxtree hbt"
# The same view without the tree (for the leaf masks).
printf 'x,y\n' > "$OUT/no-trees.csv"
sed "s|one-pine.csv|$(cd "$OUT" && pwd)/no-trees.csv|" $SCENE > "$OUT/no-trees.toml"
masks=()
for h in 800 400 200 100; do
  d=$(python3 -c "import math; print('%.2f' % (14*900/(2*math.tan(math.radians(20)))/$h))")
  z=$(python3 -c "print('%.2f' % (1100-$d))")
  common=(--size 900x900 --camera "1100,7,$z:1100,7,1100")
  p="$OUT/tree-$h"
  $S render $SCENE "${common[@]}" --spp 16 --out "$p-ref.png" 2>>"$OUT/log.txt"
  $S render $SCENE "${common[@]}" --out "$p-geometry.png" 2>>"$OUT/log.txt"
  for t in $TECHS; do
    $S render $SCENE "${common[@]}" --technique $t --out "$p-$t.png" 2>>"$OUT/log.txt"
  done
  box=$(python3 -c "h=$h; s=min(int(1.15*h),900); print(f'{450-s//2},{450-s//2},{s},{s}')")
  crop=(--crop "$box")
  row="| $h px"
  for t in geometry $TECHS; do row="$row | $(flip "$p-ref.png" "$p-$t.png" "${crop[@]}")"; done
  echo "$row |"
  $S render "$OUT/no-trees.toml" "${common[@]}" --out "$p-none.png" 2>>"$OUT/log.txt"
  m="| $h px"
  for t in geometry $TECHS; do m="$m | $(python3 scripts/mask-iou.py "$p-none.png" "$p-ref.png" "$p-$t.png" "$box" | tr ' ' '/')"; done
  masks+=("$m |")
done
echo
echo "## Leaf masks: IoU / coverage ratio of the tree's pixels vs the 16-spp reference's (scripts/mask-iou.py)"
echo "| height px | geometry 1 spp | billboard-cloud | octahedral | boxtree | hbt |"
echo "|---|---|---|---|---|---|"
printf '%s\n' "${masks[@]}"
fi

if part dolly; then
echo
echo "## Dolly 10 m → 1 km (60 frames, 320x240, fov 40): consecutive-frame FLIP"
SCENE=assets/scenes/eval/one-chestnut.toml
python3 - "$OUT" <<'PY'
import sys
out = sys.argv[1]
keys = "".join(
    f"[[key]]\nt = {t}\nposition = [1100, 7, {1100 - 10 * 100 ** (t / 60):.2f}]\nlook_at = [1100, 7, 1100]\n\n"
    for t in range(0, 61, 5)
)
open(f"{out}/dolly.toml", "w").write(f"# 10 m to 1 km from the chestnut, geometric steps\ninterpolation = \"linear\"\nfov_deg = 40\n\n{keys}")
PY
echo "| technique | median | max | max / median | frame of the max |"
echo "|---|---|---|---|---|"
for t in geometry billboard-cloud; do
  $S render $SCENE --size 320x240 --technique $t --path "$OUT/dolly.toml" --frames 60 --out "$OUT/dolly-$t.png" 2>>"$OUT/log.txt" >/dev/null
  # Around the tree only (its apparent size at frame i's distance, at least 24 px), so the
  # terrain's motion does not hide a pop.
  for i in $(seq 1 59); do
    box=$(python3 -c "import math; d=10*100**(60*$i/59/60); h=14*240/(2*math.tan(math.radians(20)))/math.hypot(d, 0); s=int(min(max(24, 1.2*h), 240)); print(f'{160-s//2},{max(120-s//2,0)},{s},{min(s,240)}')")
    flip "$OUT/dolly-$t-$(printf %03d $((i-1))).png" "$OUT/dolly-$t-$(printf %03d $i).png" --crop "$box"
  done > "$OUT/dolly-$t.txt"
  python3 - "$OUT/dolly-$t.txt" "$t" <<'PY'
import sys, statistics
v = [float(x) for x in open(sys.argv[1])]
m = statistics.median(v)
print(f"| {sys.argv[2]} | {m:.4f} | {max(v):.4f} | {max(v) / m:.2f} | {v.index(max(v)) + 1} |")
PY
done
python3 - "$OUT" <<'PY'
import math, sys
out = sys.argv[1]
g = [float(x) for x in open(f"{out}/dolly-geometry.txt")]
b = [float(x) for x in open(f"{out}/dolly-billboard-cloud.txt")]
r = [y / max(x, 1e-6) for x, y in zip(g, b)]
k = max(range(len(r)), key=r.__getitem__)
ppm = 240 / (2 * math.tan(math.radians(20)))
# Frame i is at distance 10 * 100^(i/59) (eye 7 m up: the trunk base is a little farther).
frame = lambda d: 59 * math.log(d / 10) / math.log(100)
sw = ", ".join(f"{n} {ppm / px:.0f} m ≈ frame {frame(ppm / px):.1f}" for n, px in (("mid", 24), ("far", 6)))
print(f"\nPer step, billboard-cloud / geometry: worst {r[k]:.2f} at step {k + 1}; switches: {sw}.")
PY
fi

if part broadleaf; then
echo
echo "## broadleaf.toml 640x360: FLIP vs geometry --spp 16, and bench (3 frames after warm-up, same run)"
SCENE=assets/scenes/eval/broadleaf.toml
p="$OUT/broadleaf"
$S render $SCENE --size 640x360 --spp 16 --out "$p-ref.png" 2>>"$OUT/log.txt"
echo "| technique | FLIP | median ms | ratio to geometry | triangles |"
echo "|---|---|---|---|---|"
for t in geometry billboard-cloud octahedral; do
  $S render $SCENE --size 640x360 --technique $t --out "$p-$t.png" 2>>"$OUT/log.txt"
  $S bench $SCENE --size 640x360 --technique $t --frames 3 --json > "$OUT/bench-broadleaf-$t.json" 2>>"$OUT/log.txt"
  echo "$t $(flip "$p-ref.png" "$p-$t.png")" >> "$OUT/broadleaf-flip.txt"
done
python3 - "$OUT" <<'PY'
import json, sys
out = sys.argv[1]
f = dict(l.split() for l in open(f"{out}/broadleaf-flip.txt"))
d = {t: json.load(open(f"{out}/bench-broadleaf-{t}.json")) for t in ["geometry", "billboard-cloud", "octahedral"]}
g = d["geometry"]["frame_ms"]["median"]
for t, j in d.items():
    m = j["frame_ms"]["median"]
    print(f"| {t} | {f[t]} | {m:.0f} | {m / g:.3f} | {j['triangles']:,} |")
PY
rm -f "$OUT/broadleaf-flip.txt"
fi

part bench || exit 0
echo
echo "## Chestnut forests 640x360: bench (3 frames after warm-up, same run)"
echo "| trees | technique | median ms | ratio to geometry | triangles | GPU MB |"
echo "|---|---|---|---|---|---|"
for n in 1 100 1000; do
  python3 - "$n" "$OUT" <<'PY'
import sys, math
n, out = int(sys.argv[1]), sys.argv[2]
side = math.ceil(math.sqrt(n)); sp = 14.0
with open(f"{out}/chestnuts-{n}.csv", "w") as f:
    f.write("x,y\n")
    for i in range(n):
        f.write(f"{1100 + (i % side - side / 2) * sp:.1f},{1100 + (i // side) * sp:.1f}\n")
open(f"{out}/chestnuts-{n}.toml", "w").write(f'''# {n} chestnuts on a 14 m grid (scripts/measure-bcloud.sh)
[terrain]
procedural = {{ seed = 1, size_m = 2200, relief_m = 0 }}
[[species]]
name = "chestnut"
preset = "chestnut"
positions = "chestnuts-{n}.csv"
height_m = [14, 14]
[sun]
azimuth_deg = 140
elevation_deg = 35
[camera]
position = [1100, 12, 1060]
look_at = [1100, 6, 1130]
fov_deg = 60
''')
PY
  for t in geometry billboard-cloud octahedral; do
    $S bench "$OUT/chestnuts-$n.toml" --size 640x360 --technique $t --frames 3 --json > "$OUT/bench-$n-$t.json" 2>>"$OUT/log.txt"
  done
  python3 - "$OUT" "$n" <<'PY'
import json, sys
out, n = sys.argv[1], sys.argv[2]
d = {t: json.load(open(f"{out}/bench-{n}-{t}.json")) for t in ["geometry", "billboard-cloud", "octahedral"]}
g = d["geometry"]["frame_ms"]["median"]
for t, j in d.items():
    m = j["frame_ms"]["median"]
    mem = j.get("gpu_bytes", j.get("technique_bytes", 0)) / 1e6
    print(f"| {n} | {t} | {m:.1f} | {m / g:.3f} | {j.get('triangles', 0):,} | {mem:.1f} |")
PY
done
