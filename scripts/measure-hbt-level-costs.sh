#!/usr/bin/env bash
# Reproduces the per-level costs behind `hbt`'s `LevelCosts::LAVAPIPE` (issue #15: levels chosen
# per plant from what they cost): one chestnut (14 m) and one pine (16 m) alone, 60 m away,
# fov 40, no shadows, at 256² and 512² (the tree ≈ 90 and ≈ 180 px tall), with each level
# forced — the tree billboard (levels 1), the level below (levels 2, opened at any distance),
# the meshes (opened and meshed at any distance) — and the trees pass's GPU time (median of 5
# frames after 2 warm-up), beside the bake's `branch_placements` and `branch_fill`.
# Usage: scripts/measure-hbt-level-costs.sh [OUT_DIR]   (default out/measure-hbt-level-costs; ~3 min)
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-out/measure-hbt-level-costs}
. scripts/common.sh

echo "| plant | placements | fill | triangles | size | tree billboard ms | level below ms | meshes ms |"
echo "|---|---|---|---|---|---|---|---|"
for p in chestnut pine; do
  case $p in
    chestnut) scene=assets/scenes/eval/one-chestnut.toml ;;
    pine) scene=assets/scenes/eval/one-pine.toml ;;
  esac
  bake=$($S bake --preset $p --technique hbt --json 2>>"$OUT/log.txt")
  tris=$($S plant --preset $p --stats | python3 -c 'import json,sys; print(json.load(sys.stdin)["triangles"])')
  for size in 256x256 512x512; do
    ms=()
    for set in "hbt.levels=1" "hbt.levels=2 --set hbt.open_texel_pixels=0.1" \
      "hbt.mesh_texel_pixels=0.1 --set hbt.open_texel_pixels=0.1 --set hbt.measured_switch=false"; do
      # shellcheck disable=SC2086
      ms+=("$($S bench $scene --technique hbt --size $size --frames 5 --no-shadows --set $set --json 2>>"$OUT/log.txt" |
        python3 -c 'import json,sys; print("%.1f" % json.load(sys.stdin)["split_ms"]["trees"]["median"])')")
    done
    echo "$bake" | python3 -c "
import json, sys
d = json.load(sys.stdin)
print(f\"| $p | {d['branch_placements']} | {d['branch_fill']:.2f} | $tris | $size | ${ms[0]} | ${ms[1]} | ${ms[2]} |\")"
  done
done
