#!/usr/bin/env bash
# Reproduces every boxtree figure in BENCHMARKS.md (LCV04, issue #4):
#   1. one pine at apparent heights 400/200/100/50 px: FLIP vs the 16-spp geometry reference for
#      geometry 1 spp, boxtree (diagonal and axis planes) and a naive billboard of equal
#      texture memory;
#   2. the default scene at 480x270 and 1280x720: FLIP, and bench medians boxtree vs geometry;
#   3. a 60-frame dolly from 20 m to 1 km: consecutive-frame FLIP, max/median;
#   4. bake time and image memory per preset at 64 and 128 px.
# Usage: scripts/measure-boxtree.sh [OUT_DIR]   (default out/measure-boxtree; ~20 min on lavapipe)
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-out/measure-boxtree}
. scripts/common.sh
field() { python3 -c "import json,sys; d=json.load(sys.stdin); print(d$1)"; }

echo "## Bake time and memory per preset (sylvan bake --no-cache --json)"
echo "| preset | tile | planes | boxes | images | image MB | bake ms |"
echo "|---|---|---|---|---|---|---|"
for preset in pine prunus bush; do
  for tile in 64 128; do
    j=$($S bake --preset $preset --set boxtree.tile=$tile --no-cache --json)
    echo "| $preset | $tile | $(echo "$j" | field '["planes"]') | $(echo "$j" | field '["boxes"]') | $(echo "$j" | field '["images"]') | $(echo "$j" | python3 -c 'import json,sys; print("%.2f" % (json.load(sys.stdin)["image_bytes"]/1e6))') | $(echo "$j" | python3 -c 'import json,sys; print("%.0f" % json.load(sys.stdin)["bake_ms"])') |"
  done
done

# Equal texture memory: the billboard's single image has as many texels as pine's box tree.
texels=$($S bake --preset pine --json | python3 -c 'import json,sys; d=json.load(sys.stdin); print(d["images"]*d["tile"]**2)')
bb_tile=$(python3 -c "import math; print(2**round(math.log2(math.sqrt($texels))))")
echo
echo "## One pine (16 m), 640x480, fov 40: FLIP vs geometry --spp 16 around the tree (lower is better)"
echo "boxtree pine: $texels texels of images; naive billboard: one ${bb_tile}² image"
echo "| apparent height | distance m | geometry 1 spp | boxtree diagonal | boxtree axis | naive billboard |"
echo "|---|---|---|---|---|---|"
SCENE=assets/scenes/eval/one-pine.toml
for h in 400 200 100 50; do
  d=$(python3 -c "import math; print('%.1f' % (16*480/(2*math.tan(math.radians(20)))/$h))")
  z=$(python3 -c "print('%.2f' % (1100-$d))")
  cam="1100,8,$z:1100,8,1100"
  common=(--size 640x480 --camera "$cam")
  $S render $SCENE "${common[@]}" --spp 16 --out "$OUT/tree-$h-ref.png" 2>>"$OUT/log.txt"
  $S render $SCENE "${common[@]}" --out "$OUT/tree-$h-geometry.png" 2>>"$OUT/log.txt"
  $S render $SCENE "${common[@]}" --technique boxtree --set boxtree.layout=diagonal --out "$OUT/tree-$h-diagonal.png" 2>>"$OUT/log.txt"
  $S render $SCENE "${common[@]}" --technique boxtree --set boxtree.layout=axis --out "$OUT/tree-$h-axis.png" 2>>"$OUT/log.txt"
  $S render $SCENE "${common[@]}" --technique boxtree --set boxtree.layout=billboard --set boxtree.tile="$bb_tile" --set boxtree.max_boxes=1 --set boxtree.texel_pixels=64 --out "$OUT/tree-$h-billboard.png" 2>>"$OUT/log.txt"
  r="$OUT/tree-$h-ref.png"
  # FLIP over a square of 1.3 × the tree's apparent height around it (clipped to the frame).
  crop=(--crop "$(python3 -c "h=$h; s=int(1.3*h); print(f'{max(320-s//2,0)},{max(240-s//2,0)},{s},{s}')")")
  echo "| $h px | $d | $(flip $r "$OUT/tree-$h-geometry.png" "${crop[@]}") | $(flip $r "$OUT/tree-$h-diagonal.png" "${crop[@]}") | $(flip $r "$OUT/tree-$h-axis.png" "${crop[@]}") | $(flip $r "$OUT/tree-$h-billboard.png" "${crop[@]}") |"
done

echo
echo "## Default scene: FLIP vs geometry --spp 16"
echo "| size | geometry 1 spp | boxtree diagonal | boxtree axis | 1.25 × geometry |"
echo "|---|---|---|---|---|"
for size in 480x270 1280x720; do
  $S render --size $size --spp 16 --out "$OUT/default-$size-ref.png" 2>>"$OUT/log.txt"
  $S render --size $size --out "$OUT/default-$size-geometry.png" 2>>"$OUT/log.txt"
  $S render --size $size --technique boxtree --set boxtree.layout=diagonal --out "$OUT/default-$size-diagonal.png" 2>>"$OUT/log.txt"
  $S render --size $size --technique boxtree --set boxtree.layout=axis --out "$OUT/default-$size-axis.png" 2>>"$OUT/log.txt"
  r="$OUT/default-$size-ref.png"
  g=$(flip $r "$OUT/default-$size-geometry.png")
  echo "| $size | $g | $(flip $r "$OUT/default-$size-diagonal.png") | $(flip $r "$OUT/default-$size-axis.png") | $(python3 -c "print('%.4f' % (1.25*$g))") |"
done
$S compare "$OUT/default-1280x720-ref.png" "$OUT/default-1280x720-diagonal.png" --heatmap "$OUT/flip-boxtree-1280x720.png" --json >/dev/null

echo
echo "## Default scene: bench (same run, alternating techniques twice; 5 frames after 2 warm-up each)"
echo "| size | technique | round | median ms | p95 ms | camera triangles | shadow triangles | draw calls | baked bytes |"
echo "|---|---|---|---|---|---|---|---|---|"
for size in 480x270 1280x720; do
  for round in 1 2; do
    for t in geometry boxtree boxtree-diagonal; do
      case $t in
        boxtree-diagonal) args=(--technique boxtree --set boxtree.layout=diagonal) ;;
        *) args=(--technique $t) ;;
      esac
      $S bench --size $size "${args[@]}" --frames 5 --json > "$OUT/bench-$size-$t-$round.json"
      python3 - "$OUT/bench-$size-$t-$round.json" "$size" "$t" "$round" <<'PY'
import json, sys
d = json.load(open(sys.argv[1]))
print(f"| {sys.argv[2]} | {sys.argv[3]} | {sys.argv[4]} | {d['frame_ms']['median']:.1f} | {d['frame_ms']['p95']:.1f} | {d['triangles']} | {d['shadow_triangles']} | {d['draw_calls']} | {d['baked_bytes']} |")
PY
    done
  done
  python3 - "$OUT" "$size" <<'PY'
import json, sys, statistics
out, size = sys.argv[1], sys.argv[2]
m = lambda t: statistics.median([json.load(open(f"{out}/bench-{size}-{t}-{r}.json"))["frame_ms"]["median"] for r in (1, 2)])
print(f"| {size} | **geometry / boxtree (axis, default)** | | **{m('geometry') / m('boxtree'):.1f}×** | | | | | |")
print(f"| {size} | **geometry / boxtree (diagonal)** | | **{m('geometry') / m('boxtree-diagonal'):.1f}×** | | | | | |")
PY
done
echo
echo "## Dolly 20 m → 1 km (60 frames, geometric spacing), one pine, 480x360: consecutive-frame FLIP around the tree"
python3 - "$OUT/dolly.toml" <<'PY'
import sys
keys = []
for i in range(60):
    d = 20 * (1000 / 20) ** (i / 59)
    keys.append(f"[[key]]\nt = {i}\nposition = [1100, 8, {1100 - d:.3f}]\nlook_at = [1100, 8, 1100]\n")
open(sys.argv[1], "w").write("interpolation = \"linear\"\nfov_deg = 40\n\n" + "\n".join(keys))
PY
for t in geometry boxtree; do
  mkdir -p "$OUT/dolly-$t"
  $S render $SCENE --size 480x360 --technique $t --path "$OUT/dolly.toml" --frames 60 --out "$OUT/dolly-$t/f.png" 2>>"$OUT/log.txt"
  : > "$OUT/dolly-$t.txt"
  for i in $(seq 1 59); do
    a=$(printf "%s/dolly-%s/f-%03d.png" "$OUT" $t $((i-1))); b=$(printf "%s/dolly-%s/f-%03d.png" "$OUT" $t $i)
    # Around the tree: a square of 1.3 × its apparent height in the nearer frame (16 px at least).
    crop=$(python3 -c "
import math
d = 20 * (1000 / 20) ** (($i - 1) / 59)
h = 16 * 360 / (2 * math.tan(math.radians(20))) / d
s = int(min(max(1.3 * h, 16), 360))
print(f'{240 - s // 2},{max(180 - s // 2, 0)},{s},{s}')")
    echo "$i $(flip "$a" "$b" --crop "$crop")" >> "$OUT/dolly-$t.txt"
  done
  python3 - "$OUT/dolly-$t.txt" $t <<'PY'
import sys, statistics
rows = [l.split() for l in open(sys.argv[1])]
vals = [float(v) for _, v in rows]
i = max(range(len(vals)), key=lambda k: vals[k])
d = lambda f: 20 * (1000 / 20) ** (f / 59)
print(f"{sys.argv[2]}: max {max(vals):.4f} (frames {i}->{i+1}, {d(i):.0f}->{d(i+1):.0f} m), median {statistics.median(vals):.4f}, max/median {max(vals)/statistics.median(vals):.2f}")
PY
done
