#!/usr/bin/env bash
# Reproduces the zfield figures (BN12 §5 z-fields, issue #17):
#   1. bake size and time per model (pine, prunus, chestnut; pine also at BN12's 256² tiles);
#   2. one tree (pine 16 m, prunus 12 m, chestnut 12 m) at apparent heights 256/128/64/16 px:
#      FLIP around the tree vs the 16-spp geometry reference for geometry 1 spp, zfield,
#      octahedral, boxtree and hbt;
#   3. the default scene at WxH (default 1280x720): FLIP vs geometry --spp 16 for geometry
#      1 spp, zfield, octahedral, hbt;
#   4. bench medians (3 frames) of geometry, zfield, octahedral and hbt on the default scene
#      at BENCH_SIZE (default 640x360), and of zfield, octahedral and hbt on
#      assets/scenes/bench/forest-100k.toml at 320x180 without shadows, same run.
# Usage: scripts/measure-zfield.sh [OUT_DIR] [WxH]   (default out/measure-zfield 1280x720)
# PARTS=bake,trees,scene,bench selects parts (default all).
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-out/measure-zfield}
SIZE=${2:-1280x720}
PARTS=${PARTS:-bake,trees,scene,bench}
BENCH_SIZE=${BENCH_SIZE:-640x360}
. scripts/common.sh
has() { [[ ",$PARTS," == *",$1,"* ]]; }
j() { python3 -c "import json,sys; d=json.load(sys.stdin); print($1)"; }

if has bake; then
  echo "## Bake per model (sylvan bake --technique zfield --no-cache --json)"
  echo "| plant | tile | views | image MB | bake ms |"
  echo "|---|---|---|---|---|"
  for pt in "pine 128" "prunus 128" "chestnut 128" "pine 256" "pine 64"; do
    set -- $pt
    r=$($S bake --preset $1 --technique zfield --set zfield.tile=$2 --no-cache --json)
    echo "| $1 | $2 | $(echo "$r" | j 'd["views"]') | $(echo "$r" | j '"%.1f" % (d["image_bytes"]/1e6)') | $(echo "$r" | j '"%.0f" % d["bake_ms"]') |"
  done
  echo
fi

# One-tree scenes: the pine's eval scene, and the same with the prunus / chestnut preset.
tree_scene() {
  local p=$1 h=$2 f="$OUT/one-$1.toml"
  sed "s/name = \"pine\"/name = \"$p\"/; s/preset = \"pine\"/preset = \"$p\"/; s|positions = \"one-pine.csv\"|positions = \"$PWD/assets/scenes/eval/one-pine.csv\"|; s/height_m = \[16, 16\]/height_m = [$h, $h]/" \
    assets/scenes/eval/one-pine.toml > "$f"
  echo "$f"
}

if has trees; then
  echo "## One tree, 480x480, fov 40: FLIP vs geometry --spp 16 around the tree (lower is better)"
  echo "| tree | height px | geometry 1 spp | zfield | octahedral | boxtree | hbt |"
  echo "|---|---|---|---|---|---|---|"
  for ph in "pine 16" "prunus 12" "chestnut 12"; do
    set -- $ph
    plant=$1 H=$2
    SCENE=$(tree_scene $plant $H)
    yc=$(python3 -c "print($H/2)")
    for h in 256 128 64 16; do
      d=$(python3 -c "import math; print('%.1f' % ($H*480/(2*math.tan(math.radians(20)))/$h))")
      z=$(python3 -c "print('%.2f' % (1100-$d))")
      common=(--size 480x480 --camera "1100,$yc,$z:1100,$yc,1100")
      p="$OUT/$plant-$h"
      $S render "$SCENE" "${common[@]}" --spp 16 --out "$p-ref.png" 2>>"$OUT/log.txt"
      $S render "$SCENE" "${common[@]}" --out "$p-geometry.png" 2>>"$OUT/log.txt"
      for t in zfield octahedral boxtree hbt; do
        $S render "$SCENE" "${common[@]}" --technique $t --out "$p-$t.png" 2>>"$OUT/log.txt"
      done
      crop=(--crop "$(python3 -c "h=$h; s=max(int(1.3*h),24); print(f'{max(240-s//2,0)},{max(240-s//2,0)},{min(s,480)},{min(s,480)}')")")
      row="| $plant | $h px"
      for t in geometry zfield octahedral boxtree hbt; do row="$row | $(flip "$p-ref.png" "$p-$t.png" "${crop[@]}")"; done
      echo "$row |"
    done
  done
  echo
fi

if has scene; then
  echo "## Default scene $SIZE: FLIP vs geometry --spp 16"
  echo "| geometry 1 spp | zfield | octahedral | hbt |"
  echo "|---|---|---|---|"
  p="$OUT/default-$SIZE"
  $S render --size $SIZE --spp 16 --out "$p-ref.png" 2>>"$OUT/log.txt"
  $S render --size $SIZE --out "$p-geometry.png" 2>>"$OUT/log.txt"
  for t in zfield octahedral hbt; do
    $S render --size $SIZE --technique $t --out "$p-$t.png" 2>>"$OUT/log.txt"
  done
  echo "| $(flip "$p-ref.png" "$p-geometry.png") | $(flip "$p-ref.png" "$p-zfield.png") | $(flip "$p-ref.png" "$p-octahedral.png") | $(flip "$p-ref.png" "$p-hbt.png") |"
  $S compare "$p-ref.png" "$p-zfield.png" --heatmap "$OUT/flip-zfield-$SIZE.png" --json >/dev/null
  echo
fi

if has bench; then
  echo "## Bench (same run, 3 frames each): default scene at $BENCH_SIZE; forest-100k at 320x180 without shadows"
  echo "| scene | technique | median ms | p95 ms | cpu ms | trees drawn | triangles | draw calls | baked MB | prepare ms |"
  echo "|---|---|---|---|---|---|---|---|---|---|"
  # geometry on forest-100k is left out: 3 frames at 640x360 ran over 18 minutes on lavapipe.
  for run in "default geometry" "default zfield" "default octahedral" "default hbt" \
             "forest-100k zfield" "forest-100k octahedral" "forest-100k hbt"; do
    set -- $run
    sc=$1 t=$2
    if [ "$sc" = default ]; then arg=(--size $BENCH_SIZE); else arg=(assets/scenes/bench/$sc.toml --size 320x180 --no-shadows); fi
    f="$OUT/bench-$sc-$t.json"
    $S bench "${arg[@]}" --technique $t --frames 3 --json > "$f" 2>>"$OUT/log.txt" || { echo "| $sc | $t | failed (see log) |"; continue; }
    python3 - "$f" "$sc" "$t" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
drawn = sum(d["trees_drawn"].values())
print(f"| {sys.argv[2]} | {sys.argv[3]} | {d['frame_ms']['median']:.0f} | {d['frame_ms']['p95']:.0f} | {d['cpu_ms']['median']:.2f} | {drawn} | {d['triangles']} | {d['draw_calls']} | {d['baked_bytes']/1e6:.1f} | {d['bake_ms']:.0f} |")
PY
  done
fi
