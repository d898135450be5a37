#!/usr/bin/env bash
# The far forest's hotspot (issue #18, plan M3; BENCHMARKS.md "`shadermap`: hotspot curve"):
# scene E1 (assets/scenes/eval/shadermap-flat.toml: flat, one pine species at 400/ha, sun 45°
# high from azimuth 180°), technique shadermap, the eye 8 km from the stand's centre c with a
# 2° field of view (a patch about 280 m wide: hundreds of trees per pixel row), 64×64, the
# mean linear radiance (before exposure and tone mapping) of the central 32×32, for view
# zeniths in the principal plane: on the sun's side (φ = 0, backscatter at θv = 45°) 0–80° in
# 2° steps plus 0.5° steps over 41–49°, and on the far side (φ = 180°) 0–80° in 4° steps.
# Prints the curve (side, θv, R, G, B, luminance) and the peak of the sun's side by a parabola
# through its three highest samples.
# With ZFIELD=1 also the same sweep (sun's side, 4° steps plus 1° over 41–49°) for `zfield` at
# 800 m with a 6° field of view.
# Usage: scripts/measure-hotspot.sh [OUT_DIR]   (default out/measure-hotspot)
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-out/measure-hotspot}
. scripts/common.sh
SCENE=assets/scenes/eval/shadermap-flat.toml

sweep() { # TECHNIQUE DISTANCE FOV SIDE(+1 sun's side, -1 far side) ANGLES...
  local t=$1 d=$2 fov=$3 side=$4
  shift 4
  for a in "$@"; do
    cam=$(python3 -c "
import math
a = math.radians($a); s = $side
# The sun is at azimuth 180°: towards -Z. The sun's side of c is -Z.
cx, cz = 20000.0, 21000.0
print('%.2f,%.2f,%.2f:%.1f,0,%.1f' % (cx, $d * math.cos(a), cz - s * $d * math.sin(a) + (0.01 if a == 0 else 0), cx, cz))")
    sed "s/^fov_deg = .*/fov_deg = $fov/" "$SCENE" >"$OUT/scene-fov$fov.toml"
    $S render "$OUT/scene-fov$fov.toml" --technique "$t" --size 64x64 --camera "$cam" \
      --measure 16,16,32,32 --stats "$OUT/s.json" --out "$OUT/last.png" 2>>"$OUT/log.txt" >/dev/null
    python3 -c "
import json
r, g, b = json.load(open('$OUT/s.json'))['radiance_mean']
print('%s %+d %6.2f %.5f %.5f %.5f %.5f' % ('$t', $side, $a, r, g, b, 0.2126 * r + 0.7152 * g + 0.0722 * b))"
  done
}

angles() { python3 -c "
import sys
lo, hi, step = $1, $2, $3
extra = [x / 10 for x in range(int($4 * 10), int($5 * 10) + 1, int($6 * 10))] if $6 > 0 else []
xs = sorted(set([round(lo + i * step, 2) for i in range(int((hi - lo) / step) + 1)] + extra))
print(' '.join('%g' % x for x in xs))"; }

peak() { python3 -c "
import sys
rows = [l.split() for l in open('$1') if l.startswith('$2 +1')]
pts = sorted((float(r[2]), float(r[6])) for r in rows)
i = max(range(len(pts)), key=lambda k: pts[k][1])
i = min(max(i, 1), len(pts) - 2)
(x0, y0), (x1, y1), (x2, y2) = pts[i - 1], pts[i], pts[i + 1]
den = (x0 - x1) * (x0 - x2) * (x1 - x2)
a = (x2 * (y1 - y0) + x1 * (y0 - y2) + x0 * (y2 - y1)) / den
b = (x2 * x2 * (y0 - y1) + x1 * x1 * (y2 - y0) + x0 * x0 * (y1 - y2)) / den
print('%s: peak at θv = %.2f° (parabola through %g°, %g°, %g°); the sun is at 45°' % ('$2', -b / (2 * a), x0, x1, x2))"; }

echo "# technique side θv R G B luminance (linear)"
: >"$OUT/curve.txt"
sweep shadermap 8000 2 1 $(angles 0 80 2 41 49 0.5) | tee -a "$OUT/curve.txt"
sweep shadermap 8000 2 -1 $(angles 0 80 4 0 0 0) | tee -a "$OUT/curve.txt"
if [[ ${ZFIELD:-0} == 1 ]]; then
  sweep zfield 800 6 1 $(angles 0 80 4 41 49 1) | tee -a "$OUT/curve.txt"
fi
peak "$OUT/curve.txt" shadermap
if [[ ${ZFIELD:-0} == 1 ]]; then peak "$OUT/curve.txt" zfield; fi
