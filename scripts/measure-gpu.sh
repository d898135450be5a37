#!/usr/bin/env bash
# Real-GPU frame times (issues #15, #17, #18: "on a lent GPU, absolute ms"): one prepared batch
# of `sylvan bench` runs for the `device` tool's machine, which cannot build (no network, no
# toolchain). Build and pre-bake here, carry the binary and the cache, run this there:
#
#   scripts/measure-gpu.sh prepare            # here: release build, the CPU-heavy bakes into .dev/
#   device run (carry .gl .dev):  bash scripts/measure-gpu.sh run
#
# `run` writes one JSON object per line to $OUT/bench.jsonl ({"name", "rc", "wall_s",
# "report"}), a log, and Vulkan/GL renders of the built-in forest for a backend comparison
# (`sylvan compare` them here). Every bench has its own time limit, so one slow technique costs
# its limit and the batch goes on; the order is the order of importance.
set -uo pipefail
cd "$(dirname "$0")/.."
mode=${1:-run}
# forest-1m and forest-10m with the built-in forest's chain (their files keep the default
# chain, geometry → boxtree, which is not GPU-driven) and its 8³ × 8 shader-map tables.
chained() {
  local f=assets/scenes/bench/.gpu-$1.toml
  cat assets/scenes/bench/$1.toml >"$f"
  cat >>"$f" <<'TOML'

[lod]
chain = ["geometry:0-40", "octahedral:40-150", "zfield:150-1000", "shadermap:1000-"]

[technique.shadermap]
theta = 8
phi = 8
TOML
  echo "$f"
}
C1M=$(chained forest-1m)
C10M=$(chained forest-10m)
if [ "$mode" = prepare ]; then
  set -e
  cargo build --release -q -p sylvan
  mkdir -p .dev/cache
  cp target/release/sylvan .dev/sylvan
  # The shader-map tables are the slow bakes (minutes of CPU); z-fields and impostors are GPU
  # renders the device bakes in seconds (and their bake_ms is a figure we want there).
  export SYLVAN_CACHE_DIR=$PWD/.dev/cache XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp/sylvan-xdg}
  mkdir -p -m 0700 "$XDG_RUNTIME_DIR"
  .dev/sylvan bake --technique shadermap --json | head -c 300
  .dev/sylvan bake --scene "$C1M" --technique shadermap --json | head -c 300
  .dev/sylvan bake --scene "$C10M" --technique shadermap --json | head -c 300
  # Only the tables travel (z-fields and impostors are re-baked there, on the GPU).
  mkdir -p .dev/keep
  mv .dev/cache/*shadermap* .dev/keep/ && rm -rf .dev/cache && mv .dev/keep .dev/cache
  du -sh .dev
  exit 0
fi

OUT=${OUT:-out/measure-gpu}
mkdir -p "$OUT"
S=.dev/sylvan
export SYLVAN_CACHE_DIR=$PWD/.dev/cache XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp/sylvan-xdg}
mkdir -p -m 0700 "$XDG_RUNTIME_DIR"
log="$OUT/log.txt"
jsonl="$OUT/bench.jsonl"
: >"$jsonl"
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv >>"$log" 2>&1
$S --version >>"$log" 2>&1

# bench NAME LIMIT_S ARGS…: one `sylvan bench --json` run, its report as one JSON line.
bench() {
  local name=$1 limit=$2
  shift 2
  local t0 rc rep
  t0=$(date +%s%N)
  rep=$(timeout "$limit" $S bench "$@" --json 2>>"$log")
  rc=$?
  local wall=$((($(date +%s%N) - t0) / 1000000))
  [ -n "$rep" ] || rep=null
  echo "{\"name\":\"$name\",\"rc\":$rc,\"wall_ms\":$wall,\"args\":\"$*\",\"report\":$rep}" >>"$jsonl"
  echo "$name rc=$rc wall=${wall}ms" | tee -a "$log"
}

HD=(--size 1920x1080)
B1M=assets/scenes/bench/forest-1m.toml
B10M=assets/scenes/bench/forest-10m.toml
# The built-in forest (4.9M trees, 10 km, chain geometry → octahedral → zfield → shadermap).
bench builtin-auto 60 "${HD[@]}" --frames 10
bench builtin-auto-noshadows 40 "${HD[@]}" --frames 10 --no-shadows
bench builtin-auto-nocull 60 "${HD[@]}" --frames 10 --no-caster-cull --set zfield.tight_casters=false
bench builtin-zfield 60 "${HD[@]}" --frames 10 --technique zfield
bench builtin-octahedral 60 "${HD[@]}" --frames 10 --technique octahedral
bench builtin-shadermap 30 "${HD[@]}" --frames 10 --technique shadermap
bench builtin-auto-1024x768 40 --size 1024x768 --frames 10
bench builtin-zfield-1024x768 40 --size 1024x768 --frames 10 --technique zfield
# One and ten million trees in range (trees to 2 km; BN12 §9's split is split_ms).
bench 1m-auto 60 $C1M "${HD[@]}" --frames 5
bench 1m-zfield 60 $B1M "${HD[@]}" --frames 5 --technique zfield
bench 1m-octahedral 60 $B1M "${HD[@]}" --frames 5 --technique octahedral
bench 10m-auto 60 $C10M "${HD[@]}" --frames 5
bench 10m-zfield 60 $B10M "${HD[@]}" --frames 5 --technique zfield
# Full geometry last: the slowest, and the reference of the ratios.
bench builtin-geometry 75 "${HD[@]}" --frames 3 --technique geometry
bench builtin-hbt 45 "${HD[@]}" --frames 3 --technique hbt
bench 1m-geometry 60 $B1M "${HD[@]}" --frames 2 --technique geometry
# Backends: the same picture on Vulkan and GL.
timeout 40 $S render --size 640x360 --out "$OUT/vk.png" --stats "$OUT/vk.json" >>"$log" 2>&1
echo "render vk rc=$?" | tee -a "$log"
WGPU_BACKEND=gl timeout 60 $S render --size 640x360 --out "$OUT/gl.png" --stats "$OUT/gl.json" >>"$log" 2>&1
echo "render gl rc=$?" | tee -a "$log"
