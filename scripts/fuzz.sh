#!/usr/bin/env bash
# Reproduces the fuzz campaign of docs/RELIABILITY.md: every cargo-fuzz target of fuzz/ run to
# RUNS executions (default 1,000,000) under libFuzzer's limits — 1 GiB RSS, no single
# allocation over 1 GiB, 10 s per input — then one table row per target.
#
#   scripts/fuzz.sh                  # all targets, one after the other
#   scripts/fuzz.sh gltf obj         # some targets
#   RUNS=100000 scripts/fuzz.sh      # a shorter campaign
#   MAX_TIME=600 scripts/fuzz.sh     # also stop each target after 600 s (libFuzzer -max_total_time)
#
# Needs a nightly toolchain and `cargo install cargo-fuzz`. Seeds are written by
# fuzz/make_seeds.py (from assets/ and tests' data) into fuzz/seeds/; what libFuzzer finds goes
# to fuzz/corpus/ (not committed), crashes to fuzz/artifacts/, logs to fuzz/logs/. The `cache`
# target builds sylvan-render (wgpu), so its first build is the slow one. Runs under `nice`;
# one process, one thread: it shares a small machine.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
runs="${RUNS:-1000000}"
max_time="${MAX_TIME:-0}"
all=(lsystem scene positions_csv heightmap gltf obj cache)
targets=("${@:-${all[@]}}")

max_len() {
    case "$1" in
        heightmap | gltf) echo 131072 ;; # binary formats: room for a few small buffers
        cache) echo 131072 ;;            # the seeds are 10–60 KB
        *) echo 65536 ;;                 # text formats
    esac
}

python3 fuzz/make_seeds.py
mkdir -p fuzz/logs
rows=()
for t in "${targets[@]}"; do
    features=()
    [ "$t" = cache ] && features=(--features render)
    mkdir -p "fuzz/corpus/$t" "fuzz/seeds/$t" "fuzz/artifacts/$t"
    if [ "$t" = cache ]; then
        nice -n 10 cargo +nightly fuzz build -O "${features[@]}" cache
        # The target writes its own seeds (tiny valid entries of each technique) and exits.
        SYLVAN_FUZZ_CACHE_SEEDS="fuzz/seeds/cache" \
            nice -n 10 cargo +nightly fuzz run -O "${features[@]}" cache -- -runs=0 >/dev/null
    fi
    nice -n 10 cargo +nightly fuzz build -O "${features[@]}" "$t" # not part of the timed run
    log="fuzz/logs/$t.log"
    found_before=$(find "fuzz/artifacts/$t" -type f 2>/dev/null | wc -l)
    start=$(date +%s)
    set +e
    nice -n 10 cargo +nightly fuzz run -O "${features[@]}" "$t" "fuzz/corpus/$t" "fuzz/seeds/$t" -- \
        -runs="$runs" -max_total_time="$max_time" -rss_limit_mb=1024 -malloc_limit_mb=1024 -timeout=10 \
        -max_len="$(max_len "$t")" -print_final_stats=1 >"$log" 2>&1
    rc=$?
    set -e
    secs=$(($(date +%s) - start))
    execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
    rss=$(sed -n 's/^stat::peak_rss_mb: *//p' "$log" | tail -1)
    # Crashes, OOMs, timeouts and leaks each leave one input under fuzz/artifacts/TARGET/.
    found=$(($(find "fuzz/artifacts/$t" -type f 2>/dev/null | wc -l) - found_before))
    rows+=("| $t | ${execs:-?} | $((secs / 60)) min $((secs % 60)) s | $found (exit $rc) | ${rss:-?} MB |")
    echo "${rows[-1]}"
done
echo
echo "| target | executions | wall time | crashes | peak RSS |"
echo "|---|---:|---:|---:|---:|"
printf '%s\n' "${rows[@]}"
