#!/usr/bin/env bash
# Reproduces the "hbt meshes branch by branch" figures in BENCHMARKS.md (MNP01 §4, issue #5):
# the default scene at 1280x720, FLIP vs geometry --spp 16 and bench medians (same run,
# alternating, twice) for hbt opening trees into their meshes as a whole (`--set hbt.mesh_per_branch=false`,
# the default) and branch by branch, at two mesh thresholds; and one fir seen at 3 distances.
# Needs scripts/measure-boxtree.sh's reference (out/measure-boxtree/default-1280x720-ref.png);
# renders it when missing.
# Usage: scripts/measure-hbt-branch.sh [OUT_DIR]   (default out/measure-hbt-branch; ~10 min on
# lavapipe with the reference present)
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-out/measure-hbt-branch}
REFS=out/measure-boxtree
mkdir -p "$REFS"
. scripts/common.sh
REF="$REFS/default-1280x720-ref.png"
[ -f "$REF" ] || $S render --size 1280x720 --spp 16 --out "$REF" 2>>"$OUT/log.txt"
configs=("tree 0.35" "branch 0.35" "tree 0.25" "branch 0.25")

echo "## Default scene, 1280x720: meshes by tree or by branch"
echo "| meshes by | mesh threshold px | FLIP | median ms (2 rounds) | cpu ms | camera triangles | shadow triangles | draw calls | trees meshed | branches meshed |"
echo "|---|---|---|---|---|---|---|---|---|---|"
for cfg in "${configs[@]}"; do
  set -- $cfg
  $S render --size 1280x720 --technique hbt --cpu-driven --set hbt.mesh_per_branch=$([ $1 = branch ] && echo true || echo false) --set hbt.mesh_texel_pixels=$2 --out "$OUT/default-$1-$2.png" 2>>"$OUT/log.txt"
done
for round in 1 2; do
  for cfg in geometry "${configs[@]}"; do
    set -- $cfg
    if [ "$1" = geometry ]; then
      [ $round = 1 ] && $S bench --size 1280x720 --frames 5 --json > "$OUT/bench-geometry.json"
      continue
    fi
    $S bench --size 1280x720 --technique hbt --cpu-driven --set hbt.mesh_per_branch=$([ $1 = branch ] && echo true || echo false) --set hbt.mesh_texel_pixels=$2 --frames 5 --json > "$OUT/bench-$1-$2-$round.json"
  done
done
for cfg in "${configs[@]}"; do
  set -- $cfg
  f=$(flip "$REF" "$OUT/default-$1-$2.png")
  python3 - "$OUT" "$1" "$2" "$f" <<'PY'
import json, sys, statistics
out, by, px, f = sys.argv[1:]
runs = [json.load(open(f"{out}/bench-{by}-{px}-{r}.json")) for r in (1, 2)]
geo = json.load(open(f"{out}/bench-geometry.json"))["frame_ms"]["median"]
d = runs[0]
med = [r["frame_ms"]["median"] for r in runs]
print(f"| {by} | {px} | {f} | {med[0]:.0f} / {med[1]:.0f} ({geo / statistics.mean(med):.1f}× geometry) | {d['cpu_ms']['median']:.1f} | {d['triangles']} | {d['shadow_triangles']} | {d['draw_calls']} | {d.get('hbt', {}).get('trees_meshed', 0)} | {d.get('hbt', {}).get('branches_meshed', 0)} |")
PY
done

echo
echo "## One fir (13 m), 480x480, meshes by tree or by branch: FLIP around the tree vs geometry --spp 16"
echo "| distance m | height px | geometry 1 spp | hbt by tree | hbt by branch | trees meshed by tree | branches meshed by branch |"
echo "|---|---|---|---|---|---|---|"
SCENE=assets/scenes/eval/one-fir.toml
for d in 60 120 180; do
  fir_view "$d"
  $S render $SCENE "${common[@]}" --spp 16 --out "$OUT/fir-$d-ref.png" 2>>"$OUT/log.txt"
  $S render $SCENE "${common[@]}" --out "$OUT/fir-$d-geometry.png" 2>>"$OUT/log.txt"
  row="| $d | $h | $(flip "$OUT/fir-$d-ref.png" "$OUT/fir-$d-geometry.png" "${crop[@]}") |"
  for by in tree branch; do
    $S render $SCENE "${common[@]}" --technique hbt --cpu-driven --set hbt.mesh_per_branch=$([ $by = branch ] && echo true || echo false) --out "$OUT/fir-$d-$by.png" --stats "$OUT/fir-$d-$by.json" 2>>"$OUT/log.txt"
    row="$row $(flip "$OUT/fir-$d-ref.png" "$OUT/fir-$d-$by.png" "${crop[@]}") |"
  done
  stat() { python3 -c "import json; print(json.load(open('$1')).get('hbt', {}).get('$2') or 0)"; }
  echo "$row $(stat "$OUT/fir-$d-tree.json" trees_meshed) | $(stat "$OUT/fir-$d-branch.json" branches_meshed) |"
done
