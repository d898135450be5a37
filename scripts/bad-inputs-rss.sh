#!/usr/bin/env bash
# Issue #19's numbered findings, measured: each input under crates/sylvan/tests/data/bad/ (and
# the special files tests/bad_inputs.rs makes beside them: /dev/zero links, FIFOs) run through
# the release `sylvan` binary under `/usr/bin/time -v`; one Markdown row each with the one-line
# message and the peak RSS. docs/RELIABILITY.md holds the result.
#
#   cargo build --release -p sylvan && scripts/bad-inputs-rss.sh [path/to/sylvan]
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bin="$(realpath "${1:-${CARGO_TARGET_DIR:-$root/target}/release/sylvan}")"
dir="$(mktemp -d)"
trap 'rm -rf "$dir"' EXIT
cp "$root"/crates/sylvan/tests/data/bad/* "$dir/"
cd "$dir"
for n in zero.bin zero.lsys zero.toml zero.csv zero.glb; do ln -s /dev/zero "$n"; done
mkfifo fifo.lsys fifo.toml
mkdir -p "$dir/xdg" && chmod 700 "$dir/xdg"
export XDG_RUNTIME_DIR="$dir/xdg"

run() {
    local input="$1"
    shift
    /usr/bin/time -v -o time.txt "$bin" "$@" >out.txt 2>err.txt && rc=0 || rc=$?
    local msg rss panic=""
    msg="$(grep '^error:' err.txt | head -1 | sed 's/|/\\|/g')"
    rss="$(sed -n 's/.*Maximum resident set size (kbytes): //p' time.txt)"
    grep -q panicked err.txt && panic=" **PANIC**"
    printf '| `%s` | `sylvan %s` | %s%s | %d | %s MB |\n' "$input" "$*" "$msg" "$panic" "$rc" \
        "$(awk -v k="$rss" 'BEGIN { printf "%.1f", k / 1024 }')"
}

echo "| input | command | message (one line) | exit | peak RSS |"
echo "|---|---|---|---:|---:|"
for f in gltf_stride_below_element.glb gltf_node_fanout_2pow26.glb gltf_buffer_uri_dev_zero.gltf \
    gltf_buffer_uri_bad_percent.gltf gltf_position_accessor_missing.gltf gltf_float_indices.glb \
    obj_mtllib_dev_zero.obj zero.glb zero.lsys fifo.lsys; do
    run "$f" plant "$f" --stats
done
for f in scene_*.toml zero.toml fifo.toml; do
    run "$f" render "$f" --out out.png --size 8x8
done
run png_12000x12000.png compare png_12000x12000.png png_12000x12000.png
