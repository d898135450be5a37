#!/usr/bin/env bash
# The occlusion cull (#15): each view and technique benched with and without
# `--occlusion-cull` (same run: frame time, CPU time, trees drawn and occluded), the two
# pictures compared (FLIP), and a flight's frames compared pair by pair (a tree missing for a
# frame shows as a pair that differs). Writes $OUT/occlusion.jsonl and a summary on stdout.
# Usage: scripts/measure-occlusion.sh [OUT] (default /tmp/sylvan-occlusion; ~50 min on 2 cores)
set -euo pipefail
OUT=${1:-/tmp/sylvan-occlusion}
mkdir -p "$OUT"
cargo build --release -p sylvan >/dev/null
B=target/release/sylvan
: >"$OUT/occlusion.jsonl"
# name scene camera (eye:target; "-" the scene's own); heights from the terrain at the eye.
VIEWS=(
  "1m-overview 1m -"
  "1m-ground 1m 1000,93.7,1000:1600,93.7,1600"
  "1m-canopy 1m 1000,121.7,1000:1600,100,1600"
  "10m-flight 10m 2000,340,2000:2700,230,2700"
)
bench() { # label view scene camera technique frames extra...
  local label=$1 view=$2 scene=$3 camera=$4 technique=$5 frames=$6
  shift 6
  local cam=()
  [ "$camera" = - ] || cam=(--camera "$camera")
  "$B" bench "assets/scenes/bench/forest-$scene.toml" --technique "$technique" --size 320x180 \
    --no-shadows --frames "$frames" --json "${cam[@]}" "$@" >"$OUT/one.json" 2>"$OUT/err" ||
    { echo "$label $view $technique: $(tail -1 "$OUT/err")"; return 0; }
  python3 - "$label" "$view" "$OUT" <<'PY'
import json, sys
label, view, out = sys.argv[1:4]
d = json.load(open(f"{out}/one.json"))
d["label"], d["view"] = label, view
open(f"{out}/occlusion.jsonl", "a").write(json.dumps(d) + "\n")
w = d.get("world", {})
print(f"{view:12} {d['technique']:10} {label:10} frame {d['frame_ms']['median']:9.1f} ms  cpu {d['cpu_ms']['median']:6.2f} ms"
      f"  drawn {sum(d['trees_drawn'].values()):8}  occluded {int(w.get('trees_occluded', 0)):8}  triangles {d['triangles']:11}")
PY
}
picture() { # view scene camera technique
  local view=$1 scene=$2 camera=$3 technique=$4
  local cam=()
  [ "$camera" = - ] || cam=(--camera "$camera")
  for mode in plain occlusion; do
    local flag=()
    [ "$mode" = occlusion ] && flag=(--occlusion-cull)
    "$B" render "assets/scenes/bench/forest-$scene.toml" --technique "$technique" --size 640x360 \
      --no-shadows "${cam[@]}" "${flag[@]}" --out "$OUT/$view-$technique-$mode.png" >/dev/null 2>&1
  done
  echo "picture $view $technique: $("$B" compare "$OUT/$view-$technique-plain.png" "$OUT/$view-$technique-occlusion.png" | tail -1)"
}
for v in "${VIEWS[@]}"; do
  read -r view scene camera <<<"$v"
  for technique in octahedral boxtree; do
    bench plain "$view" "$scene" "$camera" "$technique" "${FRAMES:-3}"
    bench occlusion "$view" "$scene" "$camera" "$technique" "${FRAMES:-3}" --occlusion-cull
    picture "$view" "$scene" "$camera" "$technique"
  done
done
# Geometry (whose leaves occlude) from the ground only: a frame without the cull takes ~2 min.
bench plain 1m-ground 1m 1000,93.7,1000:1600,93.7,1600 geometry 1
bench occlusion 1m-ground 1m 1000,93.7,1000:1600,93.7,1600 geometry 1 --occlusion-cull
picture 1m-ground 1m 1000,93.7,1000:1600,93.7,1600 geometry

# Flights, each frame with the cull against the same frame without (a tree missing for a
# frame shows as a pair that differs): 6 s of path in 80 frames (7.6 m apart, under the cull's
# 10 m cut). FLIGHT_TECHNIQUE over forest-10m's hills (forest-10m-flight.toml's first 600 m:
# only the terrain occludes impostors), then boxtree 30 m above forest-1m's canopy (trees
# occlude trees).
flight() { # name scene technique eye-start eye-end look-start look-end (x,y,z each)
  local name=$1 scene=$2 technique=$3
  python3 - "$OUT/$name.toml" "$4" "$5" "$6" "$7" <<'PY'
import sys
out, p0, p1, l0, l1 = sys.argv[1:6]
open(out, "w").write(f'''interpolation = "linear"
fov_deg = 55
[[key]]
t = 0
position = [{p0}]
look_at = [{l0}]
[[key]]
t = 6
position = [{p1}]
look_at = [{l1}]
''')
PY
  for mode in plain occlusion; do
    local flag=()
    [ "$mode" = occlusion ] && flag=(--occlusion-cull)
    mkdir -p "$OUT/$name-$mode"
    "$B" render "assets/scenes/bench/forest-$scene.toml" --technique "$technique" --size 160x90 \
      --no-shadows --path "$OUT/$name.toml" --frames 80 "${flag[@]}" \
      --out "$OUT/$name-$mode/f.png" >/dev/null 2>&1
  done
  for f in "$OUT/$name"-plain/*.png; do
    n=$(basename "$f")
    echo "$n $("$B" compare "$f" "$OUT/$name-occlusion/$n" --json)"
  done >"$OUT/$name.txt"
  python3 - "$OUT/$name.txt" "$name" <<'PY'
import json, sys
rows = [(l.split(" ", 1)[0], json.loads(l.split(" ", 1)[1])["flip_mean"]) for l in open(sys.argv[1])]
bad = sorted([r for r in rows if r[1] > 0.001], key=lambda r: -r[1])
print(f"{sys.argv[2]}: {len(rows)} frames, FLIP with/without the cull median {sorted(x for _, x in rows)[len(rows)//2]:.5f}"
      f" max {max(x for _, x in rows):.5f}; frames over 0.001: {len(bad)} {bad[:8]}")
PY
}
flight flight 10m "${FLIGHT_TECHNIQUE:-octahedral}" 2000.0,340,2000.0 2424.26,340,2424.26 \
  2700.0,230,2700.0 3124.26,230,3124.26
flight canopy 1m boxtree 1000.0,121.7,1000.0 1424.26,121.7,1424.26 \
  1600.0,100,1600.0 2024.26,100,2024.26
