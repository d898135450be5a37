#!/usr/bin/env bash
# Reproduces the octahedral figures (hemi-octahedral impostor, the industry baseline):
#   1. bake size and time of the pine for the grid/tile candidates;
#   2. one pine (16 m) at apparent heights 400/200/100/50 px: FLIP around the tree vs the
#      16-spp geometry reference for geometry 1 spp, octahedral (default and tuning variants),
#      boxtree and hbt;
#   3. the default scene at 1280x720: FLIP vs geometry --spp 16;
#   4. bench medians (5 frames) of geometry, octahedral, boxtree and hbt at 1280x720, same run.
# Usage: scripts/measure-octahedral.sh [OUT_DIR]   (default out/measure-octahedral)
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-out/measure-octahedral}
. scripts/common.sh

echo "## Pine bake per grid and tile (sylvan bake --technique octahedral --no-cache --json)"
echo "| grid | tile | views | image MB | bake ms |"
echo "|---|---|---|---|---|"
for gt in "8 64" "12 64" "8 128" "16 64"; do
  set -- $gt
  j=$($S bake --preset pine --technique octahedral --set octahedral.grid=$1 --set octahedral.tile=$2 --no-cache --json)
  echo "| $1 | $2 | $(echo "$j" | python3 -c 'import json,sys; print(json.load(sys.stdin)["images"])') | $(echo "$j" | python3 -c 'import json,sys; print("%.2f" % (json.load(sys.stdin)["image_bytes"]/1e6))') | $(echo "$j" | python3 -c 'import json,sys; print("%.0f" % json.load(sys.stdin)["bake_ms"])') |"
done

echo
echo "## One pine (16 m), 640x480, fov 40: FLIP vs geometry --spp 16 around the tree (lower is better)"
echo "| height px | geometry 1 spp | octahedral | oct grid 12 | oct tile 128 | oct no parallax | oct 1 view | boxtree | hbt |"
echo "|---|---|---|---|---|---|---|---|---|"
SCENE=assets/scenes/eval/one-pine.toml
for h in 400 200 100 50; do
  d=$(python3 -c "import math; print('%.1f' % (16*480/(2*math.tan(math.radians(20)))/$h))")
  z=$(python3 -c "print('%.2f' % (1100-$d))")
  common=(--size 640x480 --camera "1100,8,$z:1100,8,1100")
  p="$OUT/tree-$h"
  $S render $SCENE "${common[@]}" --spp 16 --out "$p-ref.png" 2>>"$OUT/log.txt"
  $S render $SCENE "${common[@]}" --out "$p-geometry.png" 2>>"$OUT/log.txt"
  $S render $SCENE "${common[@]}" --technique octahedral --out "$p-oct.png" 2>>"$OUT/log.txt"
  $S render $SCENE "${common[@]}" --technique octahedral --set octahedral.grid=12 --out "$p-oct-g12.png" 2>>"$OUT/log.txt"
  $S render $SCENE "${common[@]}" --technique octahedral --set octahedral.tile=128 --out "$p-oct-t128.png" 2>>"$OUT/log.txt"
  $S render $SCENE "${common[@]}" --technique octahedral --set octahedral.parallax_steps=0 --out "$p-oct-p0.png" 2>>"$OUT/log.txt"
  $S render $SCENE "${common[@]}" --technique octahedral --set octahedral.views=1 --out "$p-oct-v1.png" 2>>"$OUT/log.txt"
  $S render $SCENE "${common[@]}" --technique boxtree --out "$p-boxtree.png" 2>>"$OUT/log.txt"
  $S render $SCENE "${common[@]}" --technique hbt --out "$p-hbt.png" 2>>"$OUT/log.txt"
  crop=(--crop "$(python3 -c "h=$h; s=int(1.3*h); print(f'{max(320-s//2,0)},{max(240-s//2,0)},{s},{s}')")")
  row="| $h px"
  for t in geometry oct oct-g12 oct-t128 oct-p0 oct-v1 boxtree hbt; do row="$row | $(flip "$p-ref.png" "$p-$t.png" "${crop[@]}")"; done
  echo "$row |"
done

echo
echo "## Default scene 1280x720: FLIP vs geometry --spp 16"
echo "| geometry 1 spp | octahedral | boxtree | hbt |"
echo "|---|---|---|---|"
p="$OUT/default"
$S render --size 1280x720 --spp 16 --out "$p-ref.png" 2>>"$OUT/log.txt"
$S render --size 1280x720 --out "$p-geometry.png" 2>>"$OUT/log.txt"
for t in octahedral boxtree hbt; do
  $S render --size 1280x720 --technique $t --out "$p-$t.png" 2>>"$OUT/log.txt"
done
echo "| $(flip "$p-ref.png" "$p-geometry.png") | $(flip "$p-ref.png" "$p-octahedral.png") | $(flip "$p-ref.png" "$p-boxtree.png") | $(flip "$p-ref.png" "$p-hbt.png") |"
$S compare "$p-ref.png" "$p-octahedral.png" --heatmap "$OUT/flip-octahedral-1280x720.png" --json >/dev/null

echo
echo "## Default scene 1280x720: bench (same run, 5 frames each)"
echo "| technique | median ms | p95 ms | triangles | draw calls | baked bytes |"
echo "|---|---|---|---|---|---|"
for t in geometry octahedral boxtree hbt; do
  $S bench --size 1280x720 --technique $t --frames 5 --json > "$OUT/bench-$t.json"
  python3 - "$OUT/bench-$t.json" "$t" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
print(f"| {sys.argv[2]} | {d['frame_ms']['median']:.1f} | {d['frame_ms']['p95']:.1f} | {d['triangles']} | {d['draw_calls']} | {d['baked_bytes']} |")
PY
done
