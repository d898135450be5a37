#!/usr/bin/env bash
# The tiled world (#15): CPU per frame, startup and memory at 10k, 100k, 1M and 10M trees,
# GPU-driven against the CPU-driven frame (--cpu-driven: every tree placed up front, culled
# on the CPU each frame), same run. Writes one JSON line per run to $OUT/world.jsonl.
# Usage: [SCALE=0] [PICTURES=0] [TECHNIQUES="octahedral boxtree"] scripts/measure-world.sh [OUT]
# (default /tmp/sylvan-world; SCALE runs each of TECHNIQUES, default octahedral, PICTURES
# each of them too, default geometry and octahedral; ONLY="scene.toml …" limits PICTURES);
# ~10 min each part on 2 cores.
set -euo pipefail
OUT=${1:-/tmp/sylvan-world}
mkdir -p "$OUT"
cargo build --release -p sylvan >/dev/null
B=target/release/sylvan
: >"$OUT/world.jsonl"
run() { # label technique scene extra...
  local label=$1 technique=$2 scene=$3
  shift 3
  /usr/bin/time -f '%M' -o "$OUT/rss" "$B" bench "assets/scenes/bench/forest-$scene.toml" \
    --technique "$technique" --size 320x180 --no-shadows --frames "${FRAMES:-5}" --json "$@" \
    >"$OUT/one.json" 2>"$OUT/err" || { echo "$label $scene: $(tail -1 "$OUT/err")"; return 0; }
  python3 - "$label" "$scene" "$OUT" <<'PY'
import json, sys
label, scene, out = sys.argv[1:4]
d = json.load(open(f"{out}/one.json"))
d["label"], d["scene"], d["peak_rss_kb"] = label, scene, int(open(f"{out}/rss").read().split()[-1])
open(f"{out}/world.jsonl", "a").write(json.dumps(d) + "\n")
w = d.get("world", {})
print(f"{label:12} {scene:5} {d['technique']:10} cpu {d['cpu_ms']['median']:8.2f} ms (max {d['cpu_ms']['max']:8.2f})"
      f"  gpu {d['frame_ms']['median']:9.1f} ms  startup {d['startup_ms']:8.0f} ms  rss {d['peak_rss_kb']/1024:6.0f} MB"
      f"  drawn {sum(d['trees_drawn'].values()):8}  resident {int(w.get('trees_resident', 0)):8}  gpu_bytes {d['gpu_bytes']/2**20:6.0f} MB")
PY
}
if [ "${SCALE:-1}" = 1 ]; then
  for technique in ${TECHNIQUES:-octahedral}; do
    for scene in 10k 100k 1m 10m; do
      run gpu-driven "$technique" "$scene"
      [ "$scene" = 10m ] || run cpu-driven "$technique" "$scene" --cpu-driven
    done
  done
fi

# Same pictures: each GPU-driven technique's frame against the CPU-driven one (FLIP, trees drawn).
pictures() { # scene-or-empty label
  local scene=$1 label=$2
  for technique in ${TECHNIQUES:-geometry octahedral}; do
    for mode in gpu cpu; do
      local flag=""
      [ "$mode" = cpu ] && flag=--cpu-driven
      "$B" render $scene --technique "$technique" --size 640x360 $flag \
        --out "$OUT/$label-$technique-$mode.png" --stats "$OUT/$label-$technique-$mode.json" >/dev/null 2>&1
    done
    python3 - "$OUT" "$label" "$technique" "$("$B" compare "$OUT/$label-$technique-cpu.png" "$OUT/$label-$technique-gpu.png" --json)" <<'PY'
import json, sys
out, label, technique, cmp = sys.argv[1], sys.argv[2], sys.argv[3], json.loads(sys.argv[4])
g = json.load(open(f"{out}/{label}-{technique}-gpu.json")); c = json.load(open(f"{out}/{label}-{technique}-cpu.json"))
print(f"same-picture {label:10} {technique:10} FLIP {cmp['flip_mean']:.4f}  drawn gpu {g['trees_drawn']} cpu {c['trees_drawn']}")
PY
  done
}
if [ "${PICTURES:-1}" = 1 ]; then
  [ -n "${ONLY:-}" ] || pictures "" default
  for s in ${ONLY:-assets/scenes/eval/*.toml assets/scenes/example.toml}; do
    pictures "$s" "$(basename "$s" .toml)"
  done
fi
