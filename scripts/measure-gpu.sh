#!/usr/bin/env bash
# Real-GPU frame times (issues #15, #17, #18: "on a lent GPU, absolute ms"): one prepared batch
# of `sylvan bench` runs for the `device` tool's machine, which cannot build (no network, no
# toolchain). Build and pre-bake here, carry the binary and the cache, run this there:
#
#   scripts/measure-gpu.sh prepare            # here: release build, the CPU-heavy bakes into .dev/
#   device run (carry .gl .dev):  bash scripts/measure-gpu.sh run
#
# `run` writes one JSON object per line to $OUT/bench.jsonl ({"name", "rc", "wall_ms",
# "report"}), a log, and Vulkan/GL renders of the built-in forest for a backend comparison
# (`sylvan compare` them here). Every bench has its own time limit, so one slow technique costs
# its limit and the batch goes on; the order is the order of importance.
set -uo pipefail
cd "$(dirname "$0")/.."
mode=${1:-run}
# forest-1m and forest-10m with the built-in forest's chain (their files keep the default
# chain, geometry → boxtree, which stops at the trees) and its 8³ × 8 shader-map tables.
chained() {
  local f=assets/scenes/bench/.gpu-$1${2:-}.toml
  sed "s/^method = \"tiled\"/method = \"${2:-tiled}\"/" assets/scenes/bench/$1.toml >"$f"
  cat >>"$f" <<'TOML'

[lod]
chain = ["geometry:0-40", "boxtree:40-120", "zfield:120-1000", "shadermap:1000-"]

[technique.shadermap]
theta = 8
phi = 8
TOML
  echo "$f"
}
C1M=$(chained forest-1m)
C10M=$(chained forest-10m)
W10M=$(chained forest-10m wang)
if [ "$mode" = prepare ]; then
  set -e
  cargo build --release -q -p sylvan
  mkdir -p .dev/cache
  # Without debug info: what travels is at most 64 MiB.
  strip -o .dev/sylvan target/release/sylvan
  # The shader-map tables are the slow bakes (minutes of CPU); z-fields and impostors are GPU
  # renders the device bakes in seconds (and their bake_ms is a figure we want there).
  export SYLVAN_CACHE_DIR=$PWD/.dev/cache XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp/sylvan-xdg}
  mkdir -p -m 0700 "$XDG_RUNTIME_DIR"
  .dev/sylvan bake --technique shadermap --json | cut -c1-300
  .dev/sylvan bake --scene "$C1M" --technique shadermap --json | cut -c1-300
  .dev/sylvan bake --scene "$C10M" --technique shadermap --json | cut -c1-300
  .dev/sylvan bake --scene "$W10M" --technique shadermap --json | cut -c1-300
  # Only the tables travel (z-fields and impostors are re-baked there, on the GPU).
  mkdir -p .dev/keep
  mv .dev/cache/*shadermap* .dev/keep/ && rm -rf .dev/cache && mv .dev/keep .dev/cache
  du -sh .dev
  exit 0
fi

OUT=${OUT:-out/measure-gpu}
mkdir -p "$OUT"
S=${SYLVAN_BIN:-.dev/sylvan}
export SYLVAN_CACHE_DIR=$PWD/.dev/cache XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp/sylvan-xdg}
mkdir -p -m 0700 "$XDG_RUNTIME_DIR"
log="$OUT/log.txt"
jsonl="$OUT/bench.jsonl"
: >"$jsonl"
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv >>"$log" 2>&1
$S --version >>"$log" 2>&1

# bench NAME LIMIT_S ARGS…: one `sylvan bench --json` run, its report as one JSON line; the
# limit is cut to what is left of DEADLINE_S (the whole batch), and a run with under 20 s left
# is skipped (rc "skipped").
START=$(date +%s)
DEADLINE_S=${DEADLINE_S:-500}
# ONLY=REGEX runs the benches whose names match (a rerun of part of the batch).
ONLY=${ONLY:-.}
bench() {
  local name=$1 limit=$2
  shift 2
  [[ $name =~ $ONLY ]] || return 0
  local left=$((DEADLINE_S - ($(date +%s) - START)))
  if [ "$left" -lt 20 ]; then
    echo "{\"name\":\"$name\",\"rc\":\"skipped\",\"args\":\"$*\"}" >>"$jsonl"
    echo "$name skipped" | tee -a "$log"
    return
  fi
  [ "$limit" -lt "$left" ] || limit=$((left - 5))
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
# The built-in forest (4.9M trees, 10 km, chain geometry → octahedral → zfield → shadermap);
# the first run bakes the z-fields and impostors (bake_ms).
bench builtin-auto 90 "${HD[@]}" --frames 10
bench builtin-auto-noshadows 30 "${HD[@]}" --frames 10 --no-shadows
# One and ten million trees in range (trees to 2 km; BN12 §9's split is split_ms).
bench 1m-auto 45 "$C1M" "${HD[@]}" --frames 5 --technique auto
bench 10m-auto 45 "$C10M" "${HD[@]}" --frames 5 --technique auto
# The same 10M world under `wang`: seeded on the GPU, and on the CPU workers.
bench 10m-wang-gpuseeds 45 "$W10M" "${HD[@]}" --frames 5 --technique auto --seeds gpu
bench 10m-wang-cpuseeds 45 "$W10M" "${HD[@]}" --frames 5 --technique auto --seeds cpu
# Full geometry of the 1M world (the reference of the ratios; the first batch ran it as
# "1m-auto" without --technique auto).
bench 1m-geometry 45 "$C1M" "${HD[@]}" --frames 3 --technique geometry
# Backends: the same picture on Vulkan and GL (compare them here). EGL on a headless NVIDIA
# machine: the default platform, then surfaceless.
render() {
  local name=$1
  shift
  [[ $name =~ $ONLY ]] || return 0
  local r0
  r0=$(date +%s)
  timeout 40 env "$@" $S render --size 640x360 --out "$OUT/$name.png" --stats "$OUT/$name.json" >>"$log" 2>&1
  echo "render $name rc=$? $(($(date +%s) - r0))s" | tee -a "$log"
}
render vk WGPU_BACKEND=vulkan
render gl WGPU_BACKEND=gl
render gl-surfaceless WGPU_BACKEND=gl EGL_PLATFORM=surfaceless
# Speed at 100k trees (issue #17): one quad per tree against geometry, octahedral, hbt.
B100K=assets/scenes/bench/forest-100k.toml
for t in zfield octahedral geometry hbt; do
  bench "100k-$t" 40 $B100K "${HD[@]}" --frames 5 --technique $t
done
# BN12 §9: 180,000 trees at 1024×768 in 30 ms on a GTX 470; here the 1M world's view.
bench 1m-zfield-1024x768 30 $B1M --size 1024x768 --frames 10 --technique zfield
bench builtin-zfield 40 "${HD[@]}" --frames 10 --technique zfield
bench builtin-octahedral 40 "${HD[@]}" --frames 10 --technique octahedral
bench builtin-shadermap 20 "${HD[@]}" --frames 10 --technique shadermap
bench 1m-zfield 40 $B1M "${HD[@]}" --frames 5 --technique zfield
bench 1m-octahedral 40 $B1M "${HD[@]}" --frames 5 --technique octahedral
bench builtin-auto-1024x768 30 --size 1024x768 --frames 10
bench builtin-zfield-1024x768 30 --size 1024x768 --frames 10 --technique zfield
bench builtin-auto-nocull 40 "${HD[@]}" --frames 10 --no-caster-cull --set zfield.tight_casters=false
# A 60 s flight low over the 10M wang world at 100 m/s: frame pacing, GPU and CPU seeds.
FLIGHT=(--technique octahedral --no-shadows --frames 120 --path assets/paths/forest-10m-flight.toml)
W10=assets/scenes/bench/.gpu-forest-10m-flat-wang.toml
sed 's/^method = "tiled"/method = "wang"/' assets/scenes/bench/forest-10m.toml >"$W10"
bench flight-wang-gpuseeds 60 "$W10" "${HD[@]}" "${FLIGHT[@]}" --seeds gpu
bench flight-wang-cpuseeds 60 "$W10" "${HD[@]}" "${FLIGHT[@]}" --seeds cpu
# Full geometry last: the slowest, and the reference of the ratios.
bench builtin-geometry 60 "${HD[@]}" --frames 3 --technique geometry
bench builtin-hbt 40 "${HD[@]}" --frames 3 --technique hbt
echo "done in $(($(date +%s) - START)) s" | tee -a "$log"
