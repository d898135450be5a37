#!/usr/bin/env bash
# The built-in forest's LOD chain, chosen by measurement (issue #18 item 5): candidate chains
# that differ in the technique of the mid band (40–150 m: octahedral, hbt, boxtree,
# billboard-cloud, zfield, geometry) on a view that looks down into the forest from the
# built-in camera's eye (the mid band is the lower ~40 % of the picture, z-fields and the field
# the rest), each against 16-spp geometry of the same view: ꟻLIP of the whole picture and of
# its lower part (rows 150–270 of 270: the mid band), and the frame time (`sylvan bench`, 3
# frames after warm-up). The rule (BENCHMARKS.md "The built-in forest's chain, measured"): the
# cheapest candidate whose ꟻLIP on the lower part is within 1.25× that of `geometry` drawing
# the band (the whole picture's ꟻLIP is the z-field and field bands', the same for all).
# Usage: scripts/measure-chain.sh [OUT_DIR]   (default out/measure-chain); about 10 min of
# renders plus 2 min of benches on lavapipe once the bakes are cached.
# PHASE=all|render|bench (bench reuses the renders' PNGs and the cache); SIZE=480x270;
# CANDIDATES="octahedral hbt boxtree billboard-cloud zfield geometry". The reference takes
# about 2.5 min on lavapipe, each candidate's first run bakes its images for 4 species.
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-out/measure-chain}
PHASE=${PHASE:-all}
SIZE=${SIZE:-480x270}
CANDIDATES=${CANDIDATES:-octahedral hbt boxtree billboard-cloud zfield geometry}
. scripts/common.sh
VIEW=(--size "$SIZE" --camera "1024,278.6,716.8:1150,195,850")
H=${SIZE#*x}
W=${SIZE%x*}
LOW="0,$((H * 150 / 270)),$W,$((H - H * 150 / 270))"

chain_of() { # the chain with candidate $1 in the mid band
  case $1 in
    zfield) echo "geometry:0-40,zfield:40-1000,shadermap:1000-" ;;
    geometry) echo "geometry:0-150,zfield:150-1000,shadermap:1000-" ;;
    *) echo "geometry:0-40,$1:40-150,zfield:150-1000,shadermap:1000-" ;;
  esac
}

if [[ $PHASE != bench ]]; then
  [[ -f $OUT/ref.png ]] || $S render "${VIEW[@]}" --technique geometry --spp 16 --out "$OUT/ref.png" 2>>"$OUT/log.txt"
  [[ -f $OUT/geo1.png ]] || $S render "${VIEW[@]}" --technique geometry --out "$OUT/geo1.png" 2>>"$OUT/log.txt"
  for c in $CANDIDATES; do
    $S render "${VIEW[@]}" --technique auto --chain "$(chain_of "$c")" --out "$OUT/$c.png" 2>>"$OUT/log.txt"
  done
fi
echo "| mid band (40–150 m) | chain | ꟻLIP whole | ꟻLIP lower part | median ms | ratio to the first candidate |"
echo "|---|---|---:|---:|---:|---:|"
echo "| (geometry 1 spp) | — | $(flip "$OUT/ref.png" "$OUT/geo1.png") | $(flip "$OUT/ref.png" "$OUT/geo1.png" --crop "$LOW") | | |"
base=""
for c in $CANDIDATES; do
  ms=""
  if [[ $PHASE != render ]]; then
    ms=$($S bench "${VIEW[@]}" --technique auto --chain "$(chain_of "$c")" --frames 3 --json 2>>"$OUT/log.txt" |
      python3 -c 'import json,sys; print("%.0f" % json.load(sys.stdin)["frame_ms"]["median"])')
    base=${base:-$ms}
  fi
  ratio=$([[ -n $ms ]] && python3 -c "print('%.2f' % ($ms / $base))" || true)
  echo "| $c | \`$(chain_of "$c")\` | $(flip "$OUT/ref.png" "$OUT/$c.png") | $(flip "$OUT/ref.png" "$OUT/$c.png" --crop "$LOW") | $ms | $ratio |"
done

# Then the chosen technique's end (the z-fields' start), fidelity only: BOUNDARIES="70 100 120
# 150 200" metres (BEST=boxtree).
BEST=${BEST:-boxtree}
if [[ $PHASE != bench ]]; then
  echo
  echo "| chain | ꟻLIP whole | ꟻLIP lower part |"
  echo "|---|---:|---:|"
  for b in ${BOUNDARIES:-70 100 120 150 200}; do
    c="geometry:0-40,$BEST:40-$b,zfield:$b-1000,shadermap:1000-"
    $S render "${VIEW[@]}" --technique auto --chain "$c" --out "$OUT/$BEST-$b.png" 2>>"$OUT/log.txt"
    echo "| \`$c\` | $(flip "$OUT/ref.png" "$OUT/$BEST-$b.png") | $(flip "$OUT/ref.png" "$OUT/$BEST-$b.png" --crop "$LOW") |"
  done
fi
