# Shared set-up of the measurement scripts (sourced, from the repository root, with OUT set):
# the output and cache folders, a runtime dir for the GPU drivers, the release build, and
# `flip REF IMG [--crop …]`, which prints the mean ꟻLIP to 4 decimals.
mkdir -p "$OUT"
export SYLVAN_CACHE_DIR="$OUT/cache"
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp/sylvan-xdg}
mkdir -p -m 0700 "$XDG_RUNTIME_DIR"
cargo build --release -q -p sylvan
S=target/release/sylvan
flip() { $S compare "$1" "$2" --json "${@:3}" | python3 -c 'import json,sys; print("%.4f" % json.load(sys.stdin)["flip_mean"])'; }

# `fir_view D`: the view of assets/scenes/eval/one-fir.toml (one fir, 13 m) from D metres at
# 480x480: sets `common` (size and camera flags), `h` (the fir's height in pixels) and `crop`
# (the --crop flags of the region around it).
fir_view() {
  local z
  z=$(python3 -c "print('%.1f' % (1100-$1))")
  common=(--size 480x480 --camera "1100,6.5,$z:1100,6.5,1100")
  h=$(python3 -c "import math; print(int(13*480/(2*math.tan(math.radians(20)))/$1))")
  crop=(--crop "$(python3 -c "h=min($h,470); w=int(0.8*h); print(f'{240-w//2},{max(240-h//2-4,0)},{w},{min(h+8,480)}')")")
}
