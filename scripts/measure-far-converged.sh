#!/usr/bin/env bash
# M8 against a reference whose shadows are as fine as this machine can make them (issue #18;
# BENCHMARKS.md "M8: the reference's shadows"). The 160×160 view of
# scripts/measure-far-fidelity.sh is cut into groups of rows; each group is rendered alone as a
# "micro-view": the same eye, pitched to the group's rows, with a field of view of those rows
# (at least 1°, padded with rows above and below that are not measured), 16 columns wide (the
# central 16 of the full view), so every pixel keeps its ray and its size. Its four shadow
# cascades cover only the slant distances its receivers can have (`render --shadow-near`: from
# the nearest tree top the rows can see to past the farthest ground point, the last cascade's
# fade included), at each resolution of RES. Geometry at 16 spp is rendered at each RES (the
# ladder says how far from converged it is), each technique of TECHNIQUES at the last RES with
# the same shadow flags (like for like). Reports per band (rows weighted) the mean linear colour
# of each against the finest geometry, and the full-frame renders of M8_DIR at the same rows
# (its `ref.png`, the 2048² reference, and the techniques as shipped).
# Usage: scripts/measure-far-converged.sh [M8_DIR] [OUT_DIR]
#   M8_DIR (default out/measure-far-fidelity): a finished scripts/measure-far-fidelity.sh run
#   (its m8.toml, PNGs and cache); OUT_DIR default M8_DIR/converged.
# RES="4096 8192" TECHNIQUES="zfield auto"; TECH_RES (default the smaller of RES's last and
# 5120: `zfield`'s translucent shadow layer takes 8 B a texel more, and 8192² is past the
# renderer's shadow-memory limit) is the techniques' cascade resolution; REUSE=1 keeps PNGs
# already in OUT_DIR. About 100 s per group on two cores (24 groups).
set -euo pipefail
cd "$(dirname "$0")/.."
M8=${1:-out/measure-far-fidelity}
OUT=${2:-$M8/converged}
RES=${RES:-4096 8192}
TECHNIQUES=${TECHNIQUES:-zfield auto}
[[ -f $M8/m8.toml ]] || { echo "error: $M8/m8.toml: run scripts/measure-far-fidelity.sh $M8 first" >&2; exit 1; }
. scripts/common.sh
export SYLVAN_CACHE_DIR="$M8/cache"
TOP=${RES##* }
TECH_RES=${TECH_RES:-$((TOP < 5120 ? TOP : 5120))}

# One line per group: band, first row, rows, shadow near and far (m), micro-view rows, padding.
python3 - "$M8/m8.toml" "$OUT" > "$OUT/groups.txt" <<'EOF'
import math, re, sys
src, out = open(sys.argv[1]).read(), sys.argv[2]
H, EYE_Y, PITCH, FOV, TALLEST = 160, 250.0, 12.6, 20.0, 20.0
t = math.tan(math.radians(FOV / 2))
def ndc(edge): return 1 - 2 * edge / H
def slant(y):
    a = math.radians(PITCH) - math.atan(y * t)
    return EYE_Y / math.sin(a) if a > 0 else float('inf')
for lo, hi, n in [(3000, 5000, 8), (1500, 3000, 8), (1000, 1500, 4), (0, 1000, 4)]:
    rows = [r for r in range(H) if lo <= slant(ndc(r + 0.5)) < hi]
    k = len(rows)
    for g in range(n):
        rr = rows[g * k // n:(g + 1) * k // n]
        r0, h = min(rr), len(rr)
        hh = max(h, 9) + (max(h, 9) - h) % 2  # fov ≥ 1° (the scene's limit), padding even
        pad = (hh - h) // 2
        top, bottom = math.atan(ndc(r0 - pad) * t), math.atan(ndc(r0 + h + pad) * t)
        fov = math.degrees(top - bottom)
        pitch = math.radians(PITCH) - (top + bottom) / 2
        s_far, s_near = slant(ndc(r0)), slant(ndc(r0 + h))
        # The nearest visible receiver: a tree top the lowest row's ray grazes.
        near = max(10, int(s_near - TALLEST / math.tan(math.asin(EYE_Y / s_near))))
        # Past the farthest ground point by the cascades' 10 % fade.
        far = int(s_far / 0.88 + 20)
        s = re.sub(r'look_at = .*', 'look_at = [20000, %.4f, %.4f]'
                   % (EYE_Y - 1000 * math.sin(pitch), 15000 + 1000 * math.cos(pitch)), src)
        s = re.sub(r'fov_deg = .*', 'fov_deg = %.6f' % fov, s)
        open('%s/g%d.toml' % (out, r0), 'w').write(s)
        print(lo, r0, h, near, far, hh, pad)
EOF

render() { # render NAME SCENE TECHNIQUE RES ROWS NEAR FAR [FLAGS…]
  local name=$1 scene=$2 t=$3 res=$4 rows=$5 near=$6 far=$7
  shift 7
  [[ ${REUSE:-0} == 1 && -f $OUT/$name.png ]] && return
  $S render "$scene" --technique "$t" --size "16x$rows" --shadow-res "$res" \
    --shadow-near "$near" --shadow-distance "$far" "$@" --out "$OUT/$name.png" 2>&1 | tail -1
}
while read -r band y h near far rows pad; do
  for res in $RES; do
    render "g-$y-$res" "$OUT/g$y.toml" geometry "$res" "$rows" "$near" "$far" --spp 16
  done
  for t in $TECHNIQUES; do
    render "$t-$y" "$OUT/g$y.toml" "$t" "$TECH_RES" "$rows" "$near" "$far"
  done
done < "$OUT/groups.txt"

# Means of each group's measured rows, then per band weighted by rows.
mean() { # mean PNG X,Y,W,H → "r g b" (linear)
  $S compare "$1" "$1" --crop "$2" --json | python3 -c 'import json,sys; print(*json.load(sys.stdin)["mean_a"])'
}
while read -r band y h near far rows pad; do
  line="$band $h"
  for res in $RES; do line+=" g$res $(mean "$OUT/g-$y-$res.png" "0,$pad,16,$h")"; done
  for t in $TECHNIQUES; do line+=" $t $(mean "$OUT/$t-$y.png" "0,$pad,16,$h")"; done
  for f in ref $TECHNIQUES; do
    [[ -f $M8/$f.png ]] && line+=" full-$f $(mean "$M8/$f.png" "72,$y,16,$h")"
  done
  echo "$line"
done < "$OUT/groups.txt" > "$OUT/means.txt"
python3 - "$OUT/means.txt" "g$TOP" <<'EOF' | tee "$OUT/result.txt"
import collections, sys
lines, ref = [l.split() for l in open(sys.argv[1])], sys.argv[2]
bands = collections.OrderedDict()
for l in lines:
    band, h, rest = l[0], int(l[1]), l[2:]
    vals = {rest[i]: [float(x) for x in rest[i + 1:i + 4]] for i in range(0, len(rest), 4)}
    bands.setdefault(band, []).append((h, vals))
names = list(bands[next(iter(bands))][0][1])
label = {'0': '0.65–1 km', '1000': '1–1.5 km', '1500': '1.5–3 km', '3000': '3–5 km'}
print('mean linear colour against %s (16 spp, micro-views), R G B %%' % ref)
for band, groups in bands.items():
    H = sum(h for h, _ in groups)
    m = {n: [sum(h * v[n][c] for h, v in groups) / H for c in range(3)] for n in names}
    cells = ['%s %s' % (n, ' '.join('%+.1f' % (100 * (b / a - 1)) for a, b in zip(m[ref], m[n])))
             for n in names if n != ref]
    print('%s: %s %s | %s' % (label.get(band, band), ref, ' '.join('%.5f' % x for x in m[ref]),
                              ' | '.join(cells)))
EOF
