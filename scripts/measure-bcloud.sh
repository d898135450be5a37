#!/usr/bin/env bash
# Reproduces the billboard-cloud figures (GPSS07, issue #16):
#   1. bake time and size of the chestnut (sylvan bake --technique billboard-cloud --json);
#   2. one chestnut (14 m) at apparent heights 800/400/200/100 px, 900x900, fov 40: FLIP around
#      the tree vs geometry --spp 16 for geometry 1 spp, billboard-cloud, octahedral, boxtree, hbt;
#   3. bench medians (3 frames after warm-up) of geometry, billboard-cloud and octahedral on
#      scenes of 1, 100 and 1000 chestnuts, same run, and GPU bytes.
# Usage: scripts/measure-bcloud.sh [OUT_DIR]   (default out/measure-bcloud)
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-out/measure-bcloud}
. scripts/common.sh
json() { python3 -c "import json,sys; d=json.load(sys.stdin); print($1)"; }

echo "## Chestnut bake (sylvan bake --preset chestnut --technique billboard-cloud --no-cache --json)"
$S bake --preset chestnut --technique billboard-cloud --no-cache --json > "$OUT/bake.json"
json "f\"{d['bake_ms']/1e3:.2f} s, {d['bytes']/1e6:.2f} MB, planes {d['planes']}, {d['list_entries']:,} list entries, {d['leaves']:,} leaves\"" < "$OUT/bake.json"

echo
echo "## One chestnut (14 m), 900x900, fov 40: FLIP vs geometry --spp 16 around the tree (lower is better)"
echo "| height px | geometry 1 spp | billboard-cloud | octahedral | boxtree | hbt |"
echo "|---|---|---|---|---|---|"
SCENE=assets/scenes/eval/one-chestnut.toml
TECHS="billboard-cloud octahedral boxtree hbt"
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
  crop=(--crop "$(python3 -c "h=$h; s=min(int(1.15*h),900); print(f'{450-s//2},{450-s//2},{s},{s}')")")
  row="| $h px"
  for t in geometry $TECHS; do row="$row | $(flip "$p-ref.png" "$p-$t.png" "${crop[@]}")"; done
  echo "$row |"
done

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
