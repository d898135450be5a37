#!/usr/bin/env bash
# Reproduces the figures of hbt's small-branch level (MNP01 §7's third BTF level) in
# BENCHMARKS.md, on assets/plants/fir.lsys (main branches made of instanced boughs; the
# presets have no such level, see below):
#   1. bake time and memory of the fir with 2 and 3 BTF levels, and what the presets get;
#   2. one fir (13 m), 480x480, at 3 distances: FLIP around the tree vs geometry --spp 16 for
#      geometry at 1 spp, hbt with the main branches as the lowest level (BTF levels only),
#      with the small branches below them, and both as the default chain (meshes below);
#   3. bench medians of the same views, same run (alternating).
# Usage: scripts/measure-hbt-small.sh [OUT_DIR]   (default out/measure-hbt-small; ~4 min on lavapipe)
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-out/measure-hbt-small}
. scripts/common.sh
FIR=assets/plants/fir.lsys
SCENE=assets/scenes/eval/one-fir.toml
js() { python3 -c "import json,sys; d=json.load(sys.stdin); print($1)"; }

echo "## Bake (sylvan bake --technique hbt --no-cache --json)"
echo "| plant | levels | main objects / placements | small objects / placements | tree BTF MB | lower BTFs MB | cube-maps MB | bake ms |"
echo "|---|---|---|---|---|---|---|---|"
for src in "$FIR" --preset=pine --preset=prunus --preset=bush; do
  for small in "" --set hbt.small_branches=true; do
    j=$($S bake $src --technique hbt --no-cache --json $small)
    levels="tree, main"; [ -n "$small" ] && levels="tree, main, small"
    echo "| ${src#--preset=} | $levels | $(echo "$j" | js 'd["branch_objects"], "/", d["branch_placements"]' | tr -d "(),'") | $(echo "$j" | js 'd["small_objects"], "/", d["small_placements"]' | tr -d "(),'") | $(echo "$j" | js '"%.1f" % (d["tree_bytes"]/1e6)') | $(echo "$j" | js '"%.1f" % (d["branch_bytes"]/1e6)') | $(echo "$j" | js '"%.2f" % (d["cube_bytes"]/1e6)') | $(echo "$j" | js '"%.0f" % d["bake_ms"]') |"
  done
done

echo
echo "## One fir (13 m), 480x480: FLIP around the tree vs geometry --spp 16, bench median ms (5 frames)"
echo "hbt BTF levels: \`--set hbt.levels=2\` (no meshes); + small: \`--set hbt.small_branches=true\`; default chain: levels 3."
echo "| distance m | height px | geometry 1 spp | hbt main lowest | hbt + small | hbt default | hbt default + small | trees opened, main branches opened (+ small) | ms: geometry / main / + small / default / default + small |"
echo "|---|---|---|---|---|---|---|---|---|"
for d in 20 35 60; do
  fir_view "$d"
  $S render $SCENE "${common[@]}" --spp 16 --out "$OUT/fir-$d-ref.png" 2>>"$OUT/log.txt"
  declare -A cfg=(
    [geometry]="--technique geometry"
    [main]="--technique hbt --set hbt.levels=2"
    [small]="--technique hbt --cpu-driven --set hbt.levels=2 --set hbt.small_branches=true"
    [default]="--technique hbt"
    [default-small]="--technique hbt --cpu-driven --set hbt.small_branches=true"
  )
  row="| $d | $h"
  for k in geometry main small default default-small; do
    $S render $SCENE "${common[@]}" ${cfg[$k]} --out "$OUT/fir-$d-$k.png" --stats "$OUT/fir-$d-$k.json" 2>>"$OUT/log.txt"
    row="$row | $(flip "$OUT/fir-$d-ref.png" "$OUT/fir-$d-$k.png" "${crop[@]}")"
  done
  opened="$(js 'd.get("hbt", {}).get("trees_opened"), d.get("hbt", {}).get("branches_opened")' <"$OUT/fir-$d-small.json" | tr -d "()'")"
  ms=""
  for k in geometry main small default default-small; do
    $S bench $SCENE "${common[@]}" ${cfg[$k]} --frames 5 --json >"$OUT/bench-$d-$k.json" 2>>"$OUT/log.txt"
    ms="$ms / $(js '"%.1f" % d["frame_ms"]["median"]' <"$OUT/bench-$d-$k.json")"
  done
  echo "$row | $opened | ${ms# / } |"
done
