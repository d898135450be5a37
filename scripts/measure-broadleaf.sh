#!/usr/bin/env bash
# Reproduces the broadleaf figures (issue #16: trees with individual leaves):
#   1. plant stats of chestnut and beech (sylvan plant --stats);
#   2. bake time and size of both for octahedral, boxtree and hbt (first bake, empty cache);
#   3. assets/scenes/eval/broadleaf.toml at 640x360: FLIP vs geometry --spp 16 for geometry
#      1 spp, octahedral, boxtree and hbt;
#   4. bench medians (3 frames after 2 warm-up) of the four techniques, same run, and the
#      frame-time ratio to geometry.
# Usage: scripts/measure-broadleaf.sh [OUT_DIR]   (default out/measure-broadleaf)
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-out/measure-broadleaf}
. scripts/common.sh
SCENE=assets/scenes/eval/broadleaf.toml
TECHS="octahedral boxtree hbt"
json() { python3 -c "import json,sys; d=json.load(sys.stdin); print($1)"; }

echo "## Plants (sylvan plant --preset NAME --stats)"
echo "| preset | leaves | triangles | wood | leaf | height m |"
echo "|---|---|---|---|---|---|"
for p in chestnut beech; do
  $S plant --preset $p --stats | json "f\"| $p | {d['leaves']:,} | {d['triangles']:,} | {d['wood_triangles']:,} | {d['leaf_triangles']:,} | {d['bbox_max'][1]-d['bbox_min'][1]:.1f} |\""
done

echo
echo "## First bake per technique (sylvan bake --preset NAME --technique T --json, empty cache)"
echo "| preset | technique | bake s | images | image MB |"
echo "|---|---|---|---|---|"
for p in chestnut beech; do
  for t in $TECHS; do
    $S bake --preset $p --technique $t --json 2>>"$OUT/log.txt" > "$OUT/bake-$p-$t.json"
    json "f\"| $p | $t | {d['bake_ms']/1e3:.1f} | {d['images']} | {d['image_bytes']/1e6:.2f} |\"" < "$OUT/bake-$p-$t.json"
  done
done

echo
echo "## broadleaf.toml 640x360: FLIP vs geometry --spp 16 (lower is better)"
p="$OUT/broadleaf"
$S render $SCENE --size 640x360 --spp 16 --out "$p-ref.png" 2>>"$OUT/log.txt"
$S render $SCENE --size 640x360 --out "$p-geometry.png" 2>>"$OUT/log.txt"
for t in $TECHS; do
  $S render $SCENE --size 640x360 --technique $t --out "$p-$t.png" 2>>"$OUT/log.txt"
done
echo "| geometry 1 spp | octahedral | boxtree | hbt |"
echo "|---|---|---|---|"
echo "| $(flip "$p-ref.png" "$p-geometry.png") | $(flip "$p-ref.png" "$p-octahedral.png") | $(flip "$p-ref.png" "$p-boxtree.png") | $(flip "$p-ref.png" "$p-hbt.png") |"

echo
echo "## broadleaf.toml 640x360: bench (same run, 3 frames each after 2 warm-up)"
echo "| technique | median ms | ratio to geometry | triangles | draw calls |"
echo "|---|---|---|---|---|"
for t in geometry $TECHS; do
  $S bench $SCENE --size 640x360 --technique $t --frames 3 --json > "$OUT/bench-$t.json" 2>>"$OUT/log.txt"
done
python3 - "$OUT" $TECHS <<'PY'
import json, sys
out, techs = sys.argv[1], ["geometry"] + sys.argv[2:]
d = {t: json.load(open(f"{out}/bench-{t}.json")) for t in techs}
g = d["geometry"]["frame_ms"]["median"]
for t in techs:
    m = d[t]["frame_ms"]["median"]
    print(f"| {t} | {m:.0f} | {m / g:.3f} | {d[t]['triangles']:,} | {d[t]['draw_calls']} |")
PY
