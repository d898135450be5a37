#!/usr/bin/env bash
# Reproduces #15's "any plant" table: `hbt` against `geometry` on three scenes at 640x360 and
# 480x270 — assets/scenes/example.toml (the presets: pine, prunus, bush), the broadleaf scene
# assets/scenes/eval/broadleaf.toml (the chestnut and beech presets, with main branches), and
# the same scene with both plants IMPORTED (exported to .glb by `sylvan plant --out` and read
# back: no main branches, as a tree from another generator arrives).
# Per scene and size: ꟻLIP vs `geometry --spp 16` of geometry at 1 spp and of hbt; bench
# medians (3 frames after 2 warm-up) of geometry and hbt alternated twice in the same run; the
# ratio of each round; hbt's levels (trees meshed, plants whose level below was skipped as
# dearer than their meshes).
# Usage: scripts/measure-hbt-any-plant.sh [OUT_DIR]   (default out/measure-hbt-any-plant;
# ~25 min on lavapipe, 2 cores). SIZES="640x360" or SCENES="broadleaf" restrict it.
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${1:-out/measure-hbt-any-plant}
. scripts/common.sh
SIZES=${SIZES:-"640x360 480x270"}
SCENES=${SCENES:-"example broadleaf imported"}

# The imported broadleaf: the two presets exported as meshes, the scene pointing at them.
IMP="$OUT/imported"
mkdir -p "$IMP"
for p in chestnut beech; do
  [ -f "$IMP/$p.glb" ] || $S plant --preset $p --out "$IMP/$p.glb" > /dev/null
done
sed -e 's|^preset = "chestnut"|plant = "chestnut.glb"|' -e 's|^preset = "beech"|plant = "beech.glb"|' \
  assets/scenes/eval/broadleaf.toml > "$IMP/broadleaf-imported.toml"
grep -q 'plant = "chestnut.glb"' "$IMP/broadleaf-imported.toml"

scene_file() {
  case $1 in
    example) echo assets/scenes/example.toml ;;
    broadleaf) echo assets/scenes/eval/broadleaf.toml ;;
    imported) echo "$IMP/broadleaf-imported.toml" ;;
  esac
}

echo "| scene | size | geometry ms | hbt ms | speed | ꟻLIP geometry 1 spp | ꟻLIP hbt | ratio | trees meshed | plants without branch level |"
echo "|---|---|---|---|---|---|---|---|---|---|"
for scene in $SCENES; do
  f=$(scene_file "$scene")
  for size in $SIZES; do
    p="$OUT/$scene-$size"
    [ -f "$p-ref.png" ] || $S render "$f" --size "$size" --spp 16 --out "$p-ref.png" 2>>"$OUT/log.txt" >/dev/null
    $S render "$f" --size "$size" --out "$p-geometry.png" 2>>"$OUT/log.txt" >/dev/null
    $S render "$f" --size "$size" --technique hbt --out "$p-hbt.png" 2>>"$OUT/log.txt" >/dev/null
    fg=$(flip "$p-ref.png" "$p-geometry.png")
    fh=$(flip "$p-ref.png" "$p-hbt.png")
    for round in 1 2; do
      for t in geometry hbt; do
        $S bench "$f" --size "$size" --technique $t --frames 3 --json > "$p-bench-$t-$round.json" 2>>"$OUT/log.txt"
      done
    done
    python3 - "$p" "$scene" "$size" "$fg" "$fh" <<'PY'
import json, sys
p, scene, size, fg, fh = sys.argv[1:]
m = lambda t, r: json.load(open(f"{p}-bench-{t}-{r}.json"))
g = [m("geometry", r)["frame_ms"]["median"] for r in (1, 2)]
h = [m("hbt", r)["frame_ms"]["median"] for r in (1, 2)]
s = m("hbt", 2)["hbt"]
print(f"| {scene} | {size} | {g[0]:,.0f} / {g[1]:,.0f} | {h[0]:,.0f} / {h[1]:,.0f} | "
      f"{g[0] / h[0]:.1f}× / {g[1] / h[1]:.1f}× | {fg} | {fh} | {float(fh) / float(fg):.2f}× | "
      f"{s['trees_meshed']:.0f} | {s.get('plants_without_branch_level', 0):.0f} |")
PY
  done
done
