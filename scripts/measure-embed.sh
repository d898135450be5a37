#!/usr/bin/env bash
# Reproduces the embedding figures (issue #20):
#   1. the embedding API's picture tests (embedded vs own frame, standard Z + MSAA, occlusion);
#   2. the Bevy plugin's headless test (ꟻLIP vs sylvan render, cube/tree occlusion, plugin CPU);
#   3. the same forest's frame time in Bevy (with and without the forest) and in `sylvan bench`,
#      one after the other in this run: the built-in scene at BENCH_SIZE (default 640x360),
#      technique TECHNIQUE (default geometry), FRAMES timed frames (default 10).
# Usage: scripts/measure-embed.sh   (PARTS=embed,bevy,bench selects parts; default all)
set -euo pipefail
cd "$(dirname "$0")/.."
PARTS=${PARTS:-embed,bevy,bench}
BENCH_SIZE=${BENCH_SIZE:-640x360}
TECHNIQUE=${TECHNIQUE:-geometry}
FRAMES=${FRAMES:-10}
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp/xdg-$$}
mkdir -p -m700 "$XDG_RUNTIME_DIR"
has() { [[ ",$PARTS," == *",$1,"* ]]; }

if has embed; then
  echo "## Embedding API (cargo test -p sylvan-render --test embed)"
  cargo test -q -p sylvan-render --test embed -- --nocapture 2>&1 | grep -E "ꟻLIP|px" || true
fi
if has bevy; then
  echo "## Bevy plugin, headless (crates/sylvan-bevy: cargo test)"
  (cd crates/sylvan-bevy && WGPU_BACKEND=vulkan cargo test -q --ignore-rust-version -- --nocapture 2>&1 \
    | grep -E "ꟻLIP|pixel|silhouette|test result: .* 1 passed") || true
fi
if has bench; then
  echo "## Frame time, built-in scene, $BENCH_SIZE, $TECHNIQUE (release builds, same run)"
  cargo build -q --release -p sylvan
  (cd crates/sylvan-bevy && cargo build -q --release --ignore-rust-version --example bevy_bench)
  ./target/release/sylvan bench --size "$BENCH_SIZE" --technique "$TECHNIQUE" --frames "$FRAMES" --json \
    | python3 -c "import json,sys; d=json.load(sys.stdin); print('sylvan bench: median %.1f ms/frame (%s timer), CPU median %.3f ms/frame' % (d['frame_ms']['median'], d['timer'], d['cpu_ms']['median']))"
  WGPU_BACKEND=vulkan ./target/bevy/release/examples/bevy_bench --technique "$TECHNIQUE" --size "$BENCH_SIZE" --frames "$FRAMES" 2>/dev/null
fi
