#!/usr/bin/env bash
# Reproduces the ground-cover figures (BN12 eq. 9–12, issue #17; BENCHMARKS.md "Ground cover"):
#   1. fidelity: the built-in scene at SIZE (default 480x270), FLIP vs geometry --spp 16 for
#      geometry 1 spp, zfield and octahedral, with the ground cover (the default) and without
#      (--no-ground-occlusion, the reference rendered the same way);
#   2. the sky alone (sun below the horizon), the built-in scene from its camera: mean linear
#      radiance of a ground crop between the trees, with and without the cover;
#   3. cost: bench medians (3 frames) of zfield and geometry on the built-in scene at 640x360
#      and of zfield on assets/scenes/bench/forest-1m.toml and forest-10m.toml at 320x180
#      without shadows, with and without the cover, same run: frame ms, cpu ms, startup ms and
#      the ground cover's tiles, bytes and wait.
# Usage: scripts/measure-ground.sh [OUT_DIR] [WxH]   (default out/measure-ground 480x270)
# PARTS=fidelity,sky,cost selects parts (default all).
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-out/measure-ground}
SIZE=${2:-480x270}
PARTS=${PARTS:-fidelity,sky,cost}
. scripts/common.sh
has() { [[ ",$PARTS," == *",$1,"* ]]; }
j() { python3 -c "import json,sys; d=json.load(sys.stdin); print($1)"; }

if has fidelity; then
  echo "## Built-in scene $SIZE: FLIP vs geometry --spp 16 (the reference with the same ground)"
  echo "| ground | geometry 1 spp | zfield | octahedral |"
  echo "|---|---|---|---|"
  for g in cover none; do
    flags=(); [[ $g == none ]] && flags=(--no-ground-occlusion)
    p="$OUT/default-$g"
    $S render --size $SIZE --spp 16 "${flags[@]}" --out "$p-ref.png" 2>>"$OUT/log.txt"
    row="| $g"
    for t in geometry zfield octahedral; do
      $S render --size $SIZE --technique $t "${flags[@]}" --out "$p-$t.png" 2>>"$OUT/log.txt"
      row="$row | $(flip "$p-ref.png" "$p-$t.png")"
    done
    echo "$row |"
  done
  echo
fi

if has sky; then
  echo "## The sky alone (sun below the horizon), built-in scene $SIZE, mean linear radiance of the lower third"
  echo "| ground | technique | R | G | B |"
  echo "|---|---|---|---|---|"
  W=${SIZE%x*}; H=${SIZE#*x}
  for g in cover none; do
    flags=(); [[ $g == none ]] && flags=(--no-ground-occlusion)
    for t in geometry zfield; do
      $S render --size $SIZE --technique $t --sun 150,-5 "${flags[@]}" --measure "0,$((2*H/3)),$W,$((H/3))" \
        --stats "$OUT/sky-$g-$t.json" --out "$OUT/sky-$g-$t.png" 2>>"$OUT/log.txt"
      echo "| $g | $t | $(j '" | ".join("%.4f" % v for v in d["radiance_mean"])' < "$OUT/sky-$g-$t.json") |"
    done
  done
  echo
fi

if has cost; then
  echo "## Cost (sylvan bench … --frames 3 --json, same run)"
  echo "| scene | technique | ground | median ms | cpu ms | startup ms | cover tiles | cover MB | cover wait ms (last frame) |"
  echo "|---|---|---|---|---|---|---|---|---|"
  row() {
    local scene=$1 t=$2 g=$3; shift 3
    local flags=("$@"); [[ $g == none ]] && flags+=(--no-ground-occlusion)
    local r
    r=$($S bench $scene --technique $t --frames 3 --json "${flags[@]}" 2>>"$OUT/log.txt")
    echo "| ${scene:-built-in} | $t | $g | $(echo "$r" | j '"%.1f | %.2f | %.0f | %d | %.1f | %.2f" % (d["frame_ms"]["median"], d["cpu_ms"]["median"], d["startup_ms"], d["ground_cover"]["tiles_produced"], d["ground_cover"]["gpu_bytes"]/1e6, d["ground_cover"]["wait_ms"])') |"
  }
  for g in cover none; do
    for t in geometry zfield; do row "" $t $g --size 640x360; done
  done
  for s in forest-1m forest-10m; do
    for g in cover none; do row assets/scenes/bench/$s.toml zfield $g --size 320x180 --no-shadows; done
  done
  echo
fi
