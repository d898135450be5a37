#!/usr/bin/env bash
# `zfield`'s casters, translucent (the default: BN12 §5's soft shadows accumulated in the
# cascades' translucent layer) against opaque above α ½ (`zfield.shadow_opacity=false`)
# (issue #17; BENCHMARKS.md "Soft shadows that accumulate"):
# 1. the dense stand E1 (assets/scenes/eval/shadermap-flat.toml: pine 400/ha, sun 45° high from
#    azimuth 180°) from 800 m with a 6° field of view, 64², the mean linear luminance of the
#    central 32² at view zeniths 0°, 20° and 45° (backscatter) in the principal plane, with
#    and without shadows: the shadowed/unshadowed ratio of each against 16-spp geometry's;
# 2. ꟻLIP against 16-spp geometry: the broadleaf scene at 320×180 and the built-in forest at
#    480×270 (`zfield` alone and the default `auto` chain; the built-in reference takes about
#    2.5 min and 1-spp geometry 1.5 min on lavapipe).
# Usage: scripts/measure-soft-shadows.sh [OUT_DIR]   (default out/measure-soft-shadows)
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-out/measure-soft-shadows}
. scripts/common.sh

E1=assets/scenes/eval/shadermap-flat.toml
sed "s/^fov_deg = .*/fov_deg = 6/" "$E1" >"$OUT/e1-fov6.toml"
e1() { # ANGLE TECHNIQUE LABEL [FLAGS...] -> luminance
  local a=$1 t=$2 label=$3
  shift 3
  local cam
  cam=$(python3 -c "
import math
a = math.radians($a)
print('20000.00,%.2f,%.2f:20000,0,21000' % (800 * math.cos(a), 21000 - 800 * math.sin(a) + (0.01 if $a == 0 else 0)))")
  $S render "$OUT/e1-fov6.toml" --technique "$t" --size 64x64 --camera "$cam" \
    --measure 16,16,32,32 --stats "$OUT/$label.json" --out "$OUT/$label.png" "$@" 2>>"$OUT/log.txt" >/dev/null
  python3 -c "
import json
r, g, b = json.load(open('$OUT/$label.json'))['radiance_mean']
print('%.5f' % (0.2126 * r + 0.7152 * g + 0.0722 * b))"
}

echo "# E1 from 800 m: view zenith, shadowed / unshadowed luminance ratio (unshadowed luminance)"
echo "| θv | geometry 16 spp | zfield, translucent (default) | zfield, opaque above α ½ |"
echo "|---|---:|---:|---:|"
for a in 0 20 45; do
  g=$(e1 "$a" geometry "geo-$a" --spp 16)
  gn=$(e1 "$a" geometry "geo-ns-$a" --spp 16 --no-shadows)
  zs=$(e1 "$a" zfield "soft-$a")
  zb=$(e1 "$a" zfield "opaque-$a" --set zfield.shadow_opacity=false)
  zn=$(e1 "$a" zfield "z-ns-$a" --no-shadows)
  python3 -c "print('| %s° | %.3f (%.4f) | %.3f (%.4f) | %.3f |' % ($a, $g / $gn, $gn, $zs / $zn, $zn, $zb / $zn))"
done

echo
echo "# ꟻLIP against 16-spp geometry"
BL=assets/scenes/eval/broadleaf.toml
$S render "$BL" --size 320x180 --spp 16 --out "$OUT/bl-ref.png" 2>>"$OUT/log.txt"
$S render "$BL" --size 320x180 --out "$OUT/bl-geo.png" 2>>"$OUT/log.txt"
$S render "$BL" --size 320x180 --technique zfield --out "$OUT/bl-soft.png" 2>>"$OUT/log.txt"
$S render "$BL" --size 320x180 --technique zfield --set zfield.shadow_opacity=false \
  --out "$OUT/bl-opaque.png" 2>>"$OUT/log.txt"
echo "broadleaf 320x180: geometry 1 spp $(flip "$OUT/bl-ref.png" "$OUT/bl-geo.png"), zfield translucent $(flip "$OUT/bl-ref.png" "$OUT/bl-soft.png"), opaque $(flip "$OUT/bl-ref.png" "$OUT/bl-opaque.png")"
$S render --size 480x270 --technique geometry --spp 16 --out "$OUT/def-ref.png" 2>>"$OUT/log.txt"
$S render --size 480x270 --technique geometry --out "$OUT/def-geo.png" 2>>"$OUT/log.txt"
for t in zfield auto; do
  $S render --size 480x270 --technique $t --out "$OUT/def-$t-soft.png" 2>>"$OUT/log.txt"
  $S render --size 480x270 --technique $t --set zfield.shadow_opacity=false \
    --out "$OUT/def-$t-opaque.png" 2>>"$OUT/log.txt"
  echo "built-in 480x270, $t: translucent $(flip "$OUT/def-ref.png" "$OUT/def-$t-soft.png"), opaque $(flip "$OUT/def-ref.png" "$OUT/def-$t-opaque.png")"
done
echo "built-in 480x270: geometry 1 spp $(flip "$OUT/def-ref.png" "$OUT/def-geo.png")"
