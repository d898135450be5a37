#!/usr/bin/env bash
# Reproduces every hbt figure in BENCHMARKS.md (MNP01, issue #5):
#   1. bake time and memory per preset (tree BTF, branch-level BTFs, branch cube-maps);
#   2. relighting: one pine under 8 sun directions at 3 distances, FLIP vs the 16-spp geometry
#      reference for hbt (default: near trees drawn as meshes), hbt with the BTF levels only,
#      a view-only impostor baked under one fixed light (BTF levels only), and boxtree;
#   3. the default scene: FLIP at 480x270 and 1280x720 (default, BTF levels only, sun from
#      cube-maps, tree level only), and bench medians hbt vs geometry in the same run
#      (alternating, twice);
#   4. per level: geometry vs hbt with every tree closed (level 1) and every tree opened
#      into its branches (level 2) on the default scene at 480x270, same run.
# Needs the references of scripts/measure-boxtree.sh (out/measure-boxtree/default-*-ref.png);
# renders them when missing.
# Usage: scripts/measure-hbt.sh [OUT_DIR]   (default out/measure-hbt; ~8 min on lavapipe with the
# boxtree references present, ~25 min without)
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-out/measure-hbt}
REFS=out/measure-boxtree
mkdir -p "$REFS"
. scripts/common.sh
mb() { python3 -c "import json,sys; print('%.2f' % (json.load(sys.stdin)['$1']/1e6))"; }

echo "## Bake time and memory per preset (sylvan bake --technique hbt --no-cache --json)"
echo "| preset | tree BTF MB | branch objects | placements | branch BTFs MB | branch cube-maps MB | bake ms |"
echo "|---|---|---|---|---|---|---|"
for preset in pine prunus bush; do
  j=$($S bake --preset $preset --technique hbt --no-cache --json)
  echo "| $preset | $(echo "$j" | mb tree_bytes) | $(echo "$j" | python3 -c 'import json,sys; print(json.load(sys.stdin)["branch_objects"])') | $(echo "$j" | python3 -c 'import json,sys; print(json.load(sys.stdin)["branch_placements"])') | $(echo "$j" | mb branch_bytes) | $(echo "$j" | mb cube_bytes) | $(echo "$j" | python3 -c 'import json,sys; print("%.0f" % json.load(sys.stdin)["bake_ms"])') |"
done

echo
echo "## Relighting: one pine (16 m), 640x480, FLIP around the tree vs geometry --spp 16"
echo "Fixed light: the impostor reconstructs every tree under azimuth 200°, elevation 40° (the scene's own sun)."
echo "| sun az/el | height px | hbt (default) | hbt BTF levels only | fixed-light impostor (BTF levels) | boxtree | geometry 1 spp |"
echo "|---|---|---|---|---|---|---|"
SCENE=assets/scenes/eval/one-pine.toml
fixed=$(python3 -c "import math; a,e=math.radians(200),math.radians(40); print(f'{math.sin(a)*math.cos(e)},{math.sin(e)},{math.cos(a)*math.cos(e)}')")
for sun in 200,40 20,40 110,30 290,30 200,8 20,8 110,70 0,88; do
  for h in 200 60 30; do
    d=$(python3 -c "import math; print('%.1f' % (16*480/(2*math.tan(math.radians(20)))/$h))")
    z=$(python3 -c "print('%.2f' % (1100-$d))")
    common=(--size 640x480 --camera "1100,8,$z:1100,8,1100" --sun "$sun")
    tag="${sun/,/-}-$h"
    $S render $SCENE "${common[@]}" --spp 16 --out "$OUT/relight-$tag-ref.png" 2>>"$OUT/log.txt"
    $S render $SCENE "${common[@]}" --out "$OUT/relight-$tag-geometry.png" 2>>"$OUT/log.txt"
    $S render $SCENE "${common[@]}" --technique hbt --out "$OUT/relight-$tag-hbt.png" 2>>"$OUT/log.txt"
    $S render $SCENE "${common[@]}" --technique hbt --set hbt.levels=2 --out "$OUT/relight-$tag-hbt-btf.png" 2>>"$OUT/log.txt"
    $S render $SCENE "${common[@]}" --technique hbt --set hbt.levels=2 --set "hbt.fixed_light=[$fixed]" --out "$OUT/relight-$tag-fixed.png" 2>>"$OUT/log.txt"
    $S render $SCENE "${common[@]}" --technique boxtree --out "$OUT/relight-$tag-boxtree.png" 2>>"$OUT/log.txt"
    crop=(--crop "$(python3 -c "h=$h; s=int(1.3*h); print(f'{max(320-s//2,0)},{max(240-s//2,0)},{s},{s}')")")
    r="$OUT/relight-$tag-ref.png"
    echo "| $sun | $h | $(flip $r "$OUT/relight-$tag-hbt.png" "${crop[@]}") | $(flip $r "$OUT/relight-$tag-hbt-btf.png" "${crop[@]}") | $(flip $r "$OUT/relight-$tag-fixed.png" "${crop[@]}") | $(flip $r "$OUT/relight-$tag-boxtree.png" "${crop[@]}") | $(flip $r "$OUT/relight-$tag-geometry.png" "${crop[@]}") |"
  done
done

echo
echo "## Tree level baked from geometry or rendered from the branches (MNP01 §6.1), tree level drawn alone"
echo "| sun az/el | height px | from geometry (default) | from branches (--set hbt.tree_from_branches=true) |"
echo "|---|---|---|---|"
for sun in 200,40 20,8; do
  for h in 60 30; do
    d=$(python3 -c "import math; print('%.1f' % (16*480/(2*math.tan(math.radians(20)))/$h))")
    z=$(python3 -c "print('%.2f' % (1100-$d))")
    tag="${sun/,/-}-$h"
    crop=(--crop "$(python3 -c "h=$h; s=int(1.3*h); print(f'{max(320-s//2,0)},{max(240-s//2,0)},{s},{s}')")")
    row="| $sun | $h |"
    for from in geometry branches; do
      $S render $SCENE --size 640x480 --camera "1100,8,$z:1100,8,1100" --sun "$sun" --technique hbt --set hbt.levels=2 --set hbt.open_texel_pixels=16 --set hbt.tree_from_branches=$([ $from = branches ] && echo true || echo false) --out "$OUT/tree-from-$from-$tag.png" 2>>"$OUT/log.txt"
      row="$row $(flip "$OUT/relight-$tag-ref.png" "$OUT/tree-from-$from-$tag.png" "${crop[@]}") |"
    done
    echo "$row"
  done
done

echo
echo "## Default scene: FLIP vs geometry --spp 16"
echo "| size | geometry 1 spp | hbt (default: 3 levels, sun from cascades) | hbt BTF levels only (levels 2) | hbt levels 2, sun from cube-maps | hbt level 1 only | hbt, tree level from branches |"
echo "|---|---|---|---|---|---|---|"
for size in 480x270 1280x720; do
  ref="$REFS/default-$size-ref.png"
  [ -f "$ref" ] || $S render --size $size --spp 16 --out "$ref" 2>>"$OUT/log.txt"
  [ -f "$REFS/default-$size-geometry.png" ] || $S render --size $size --out "$REFS/default-$size-geometry.png" 2>>"$OUT/log.txt"
  $S render --size $size --technique hbt --out "$OUT/default-$size-hbt.png" --stats "$OUT/default-$size-hbt.json" 2>>"$OUT/log.txt"
  $S render --size $size --technique hbt --set hbt.levels=2 --out "$OUT/default-$size-hbt-l2.png" 2>>"$OUT/log.txt"
  $S render --size $size --technique hbt --cpu-driven --set hbt.levels=2 --set hbt.shadows=cubemaps --out "$OUT/default-$size-hbt-cubemaps.png" 2>>"$OUT/log.txt"
  $S render --size $size --technique hbt --set hbt.levels=1 --out "$OUT/default-$size-hbt-l1.png" 2>>"$OUT/log.txt"
  $S render --size $size --technique hbt --set hbt.tree_from_branches=true --out "$OUT/default-$size-hbt-composed.png" 2>>"$OUT/log.txt"
  echo "| $size | $(flip "$ref" "$REFS/default-$size-geometry.png") | $(flip "$ref" "$OUT/default-$size-hbt.png") | $(flip "$ref" "$OUT/default-$size-hbt-l2.png") | $(flip "$ref" "$OUT/default-$size-hbt-cubemaps.png") | $(flip "$ref" "$OUT/default-$size-hbt-l1.png") | $(flip "$ref" "$OUT/default-$size-hbt-composed.png") |"
done
python3 - "$OUT/default-480x270-hbt.json" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
print(f"\nVisibility structure (default scene, {d['trees_total']} trees): {d['hbt']['visibility_bytes']/1e6:.1f} MB, built in {d['hbt']['visibility_ms']:.0f} ms; trees opened at 480x270: {d['hbt']['trees_opened']}; camera triangles {d['triangles']}")
PY

echo
echo "## Default scene: bench (same run, alternating twice; 5 frames after warm-up)"
echo "| size | technique | round | median ms | p95 ms | cpu ms | camera triangles | draw calls |"
echo "|---|---|---|---|---|---|---|---|"
for size in 480x270 1280x720; do
  for round in 1 2; do
    for t in geometry hbt hbt-l2 hbt-l1 hbt-open; do
      case $t in
        hbt-l2) args=(--technique hbt --set hbt.levels=2) ;;
        hbt-l1) args=(--technique hbt --set hbt.levels=1) ;;
        hbt-open) args=(--technique hbt --set hbt.levels=2 --set hbt.open_texel_pixels=0.1) ;;
        *) args=(--technique $t) ;;
      esac
      [ "$size" = 1280x720 ] && [ "$t" = hbt-open ] && continue
      $S bench --size $size "${args[@]}" --frames 5 --json > "$OUT/bench-$size-$t-$round.json"
      python3 - "$OUT/bench-$size-$t-$round.json" "$size" "$t" "$round" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
print(f"| {sys.argv[2]} | {sys.argv[3]} | {sys.argv[4]} | {d['frame_ms']['median']:.1f} | {d['frame_ms']['p95']:.1f} | {d['cpu_ms']['median']:.1f} | {d['triangles']} | {d['draw_calls']} |")
PY
    done
  done
  python3 - "$OUT" "$size" <<'PY'
import json, sys, statistics, os
out, size = sys.argv[1], sys.argv[2]
def m(t):
    return statistics.median([json.load(open(f"{out}/bench-{size}-{t}-{r}.json"))["frame_ms"]["median"] for r in (1, 2)])
print(f"| {size} | **geometry / hbt (default: 3 levels)** | | **{m('geometry') / m('hbt'):.1f}×** | | | | |")
print(f"| {size} | **geometry / hbt BTF levels only (levels 2)** | | **{m('geometry') / m('hbt-l2'):.1f}×** | | | | |")
print(f"| {size} | **geometry / hbt level 1 (every tree closed)** | | **{m('geometry') / m('hbt-l1'):.1f}×** | | | | |")
if os.path.exists(f"{out}/bench-{size}-hbt-open-1.json"):
    print(f"| {size} | **geometry / hbt level 2 (every tree opened)** | | **{m('geometry') / m('hbt-open'):.1f}×** | | | | |")
PY
done
