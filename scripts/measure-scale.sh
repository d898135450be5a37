#!/usr/bin/env bash
# Scale consistency (BN12 fig. 7; issue #18, plan M2; BENCHMARKS.md "`shadermap`: scale
# consistency"): scene E1 (assets/scenes/eval/shadermap-flat.toml, chain B: zfield to 1.5 km,
# the field beyond), technique auto, 320×180, fov 30°, the mean linear radiance of the central
# 80×45 px of a forest patch at c seen from distance s along 8 directions (view zenith θv in
# {5°, 30°, 50°, 65°}, azimuth from the sun φ in {0°, 180°}), s in DISTANCES; J jitters (c
# moved by j × (173, 0, 311) m, sun and eye azimuth both turned by 45° j so φ is kept).
# Prints L(θv, φ, s) / L(θv, φ, 50 m) per direction and distance (mean over the jitters of
# the per-jitter ratio, and its standard error), then the largest |ratio − 1|.
# Usage: scripts/measure-scale.sh [OUT_DIR]   (default out/measure-scale)
# J=2 jitters (default), DISTANCES="50 100 200 400 800 1600 3200 5000", TECHNIQUE=auto,
# DIRS="5:0 5:180 30:0 30:180 50:0 50:180 65:0 65:180" (θv:φ; a subset for a quick look).
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-out/measure-scale}
J=${J:-2}
DISTANCES=${DISTANCES:-50 100 200 400 800 1600 3200 5000}
TECHNIQUE=${TECHNIQUE:-auto}
DIRS=${DIRS:-5:0 5:180 30:0 30:180 50:0 50:180 65:0 65:180}
. scripts/common.sh
SCENE="$OUT/e1-fov30.toml"
sed "s/^fov_deg = .*/fov_deg = 30/" assets/scenes/eval/shadermap-flat.toml >"$SCENE"

: >"$OUT/radiance.txt"
for j in $(seq 0 $((J - 1))); do
  for dir in $DIRS; do
    tv=${dir%:*}
    phi=${dir#*:}
    for s in $DISTANCES; do
      read -r cam sun < <(python3 -c "
import math
j, tv, phi, s = $j, math.radians($tv), $phi, $s
az = 180 + 45 * j
c = (20000 + 173 * j, 0.0, 20000 + 311 * j)
a = math.radians(az + phi)
e = (c[0] + s * math.sin(tv) * math.sin(a), s * math.cos(tv), c[2] + s * math.sin(tv) * math.cos(a))
print('%.2f,%.2f,%.2f:%.2f,0,%.2f %g,45' % (e[0], e[1], e[2], c[0], c[2], az % 360))")
      $S render "$SCENE" --technique "$TECHNIQUE" --size 320x180 --camera "$cam" --sun "$sun" \
        --measure 120,68,80,45 --stats "$OUT/s.json" --out "$OUT/j$j-$tv-$phi-$s.png" \
        2>>"$OUT/log.txt" >/dev/null
      python3 -c "
import json
r, g, b = json.load(open('$OUT/s.json'))['radiance_mean']
print($j, $tv, $phi, $s, 0.2126 * r + 0.7152 * g + 0.0722 * b)" | tee -a "$OUT/radiance.txt"
    done
  done
done

python3 - "$OUT/radiance.txt" <<'EOF'
import sys, math, collections
rows = [l.split() for l in open(sys.argv[1]) if l.strip()]
lum = {(int(j), int(t), int(p), int(s)): float(v) for j, t, p, s, v in rows}
dists = sorted({k[3] for k in lum})
base = dists[0]
print("| θv | φ | " + " | ".join("%d m" % d for d in dists) + " |")
print("|---|---|" + "---|" * len(dists))
worst = 0.0
for t in (5, 30, 50, 65):
    for p in (0, 180):
        cells = []
        for d in dists:
            r = [lum[(j, t, p, d)] / lum[(j, t, p, base)]
                 for j in sorted({k[0] for k in lum}) if (j, t, p, d) in lum and (j, t, p, base) in lum]
            if not r:
                cells.append("—")
                continue
            m = sum(r) / len(r)
            se = (math.sqrt(sum((x - m) ** 2 for x in r) / (len(r) - 1) / len(r)) if len(r) > 1 else float("nan"))
            worst = max(worst, abs(m - 1))
            cells.append("%.3f ± %.3f" % (m, se))
        print("| %d° | %d° | %s |" % (t, p, " | ".join(cells)))
print("largest |ratio − 1|: %.1f %%" % (100 * worst))
EOF
