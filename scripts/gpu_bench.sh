#!/usr/bin/env bash
# The rows of docs/benchmarks.md "On a GPU": the release binary's throughput on
# a machine with a GPU, one run each (read them as orders of magnitude).
#   scripts/gpu_bench.sh OUTDIR [BINARY]
# BINARY defaults to target/release/swarmshot (build it where cargo reaches the
# crates, copy it over). Prints and writes OUTDIR/gpu_bench.txt; each batch's
# "wrote … on ADAPTER" line names the adapter it ran on, its "per frame" line
# the makers' and encoders' busy time (--timings), and bash's time its wall,
# user and system seconds; the 2 400-frame run also the GPU's load a second
# (OUTDIR/dmon.txt). Datasets go to /dev/shm when there is one.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:?usage: scripts/gpu_bench.sh OUTDIR [BINARY]}
bin=$(realpath "${2:-target/release/swarmshot}")
mkdir -p "$out"
work=$(mktemp -d)
scratch=$(mktemp -d -p "$([ -d /dev/shm ] && echo /dev/shm || echo "$work")")
trap 'rm -rf "$work" "$scratch"' EXIT
export SWARMSHOT_CACHE_DIR="$work/cache"
TIMEFORMAT='  %R s wall, %U s user, %S s sys'

# One batch into a fresh folder: its summary lines and its times.
batch() {
    echo "== $*"
    { time "$bin" batch "$@" --out "$scratch/ds" --overwrite --timings 2>&1 | grep -E "^(wrote|error|per frame)"; } 2>&1
    rm -rf "$scratch/ds"
}

{
    nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader 2>/dev/null || echo "no nvidia-smi"
    echo "cores: $(nproc)"
    lscpu 2>/dev/null | grep -E "^(Thread|Core|Socket)" || true
    batch presets/quickstart.ron
    for makers in 6 12 16 24; do
        batch presets/synthswarm_table2.ron --limit 1200 --makers "$makers"
    done
    batch presets/synthswarm_table2.ron --limit 1200 --makers 16 --threads 16
    # The GPU's load through the longest run (its SMs' busy share a second);
    # bounded in time, so a batch that stops the script cannot leave it running.
    dmon=
    if command -v nvidia-smi > /dev/null; then
        timeout 600 nvidia-smi dmon -s u -d 1 > "$out/dmon.txt" 2>&1 &
        dmon=$!
    fi
    batch presets/synthswarm_table2.ron --limit 2400 --makers 16
    if [ -n "$dmon" ]; then
        kill "$dmon" 2> /dev/null || true
        echo "  GPU load (nvidia-smi dmon, sm %): $(awk '!/^#/ {printf "%s ", $2}' "$out/dmon.txt")"
    fi
    for makers in 12 16; do
        batch presets/realistic.ron --limit 600 --makers "$makers"
    done
} 2>&1 | tee "$out/gpu_bench.txt"
