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
