#!/usr/bin/env bash
# BN12 §4's "trees under 3 px are never drawn" (issue #18 item 4): the built-in forest's view
# and the chain view of `measure-chain.sh`, 480×270, with `shadermap.handover_px` 0 (every tree
# drawn to the field's start: the behaviour before the rule), 1, 2 and 3 (the default): ꟻLIP
# against 16-spp geometry of the same view, z-field trees drawn, and the frame time (`sylvan
# bench`, 3 frames, ROUNDS alternated rounds of 0 and 3).
# Usage: scripts/measure-pixel-rule.sh [OUT_DIR]   (default out/measure-pixel-rule); about 15 min
# on lavapipe with the bakes cached (the two references take ~2.5 min each).
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-out/measure-pixel-rule}
ROUNDS=${ROUNDS:-2}
. scripts/common.sh
declare -A VIEWS=([builtin]="--size 480x270" [chain]="--size 480x270 --camera 1024,278.6,716.8:1150,195,850")
drawn() { python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["trees_drawn"].get("zfield", 0))' "$1"; }
ms() { python3 -c 'import json,sys; print("%.0f" % json.load(sys.stdin)["frame_ms"]["median"])'; }
echo "| view | handover_px | ꟻLIP | z-field trees drawn |"
echo "|---|---:|---:|---:|"
for v in builtin chain; do
  read -ra view <<<"${VIEWS[$v]}"
  [[ -f $OUT/$v-ref.png ]] || $S render "${view[@]}" --technique geometry --spp 16 --out "$OUT/$v-ref.png" 2>>"$OUT/log.txt"
  [[ -f $OUT/$v-geo1.png ]] || $S render "${view[@]}" --technique geometry --out "$OUT/$v-geo1.png" 2>>"$OUT/log.txt"
  echo "| $v | (geometry 1 spp) | $(flip "$OUT/$v-ref.png" "$OUT/$v-geo1.png") | |"
  for px in 0 1 2 3; do
    $S render "${view[@]}" --technique auto --set shadermap.handover_px=$px --out "$OUT/$v-px$px.png" \
      --stats "$OUT/$v-px$px.json" 2>>"$OUT/log.txt" >/dev/null
    echo "| $v | $px | $(flip "$OUT/$v-ref.png" "$OUT/$v-px$px.png") | $(drawn "$OUT/$v-px$px.json") |"
  done
done
echo
echo "| view | round | ms, handover_px 0 | ms, handover_px 3 |"
echo "|---|---:|---:|---:|"
for r in $(seq "$ROUNDS"); do
  for v in builtin chain; do
    read -ra view <<<"${VIEWS[$v]}"
    a=$($S bench "${view[@]}" --technique auto --set shadermap.handover_px=0 --frames 3 --json 2>>"$OUT/log.txt" | ms)
    b=$($S bench "${view[@]}" --technique auto --frames 3 --json 2>>"$OUT/log.txt" | ms)
    echo "| $v | $r | $a | $b |"
  done
done
