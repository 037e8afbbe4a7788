#!/usr/bin/env bash
# The rows of docs/benchmarks.md "On a GPU": the release binary's throughput on
# a machine with a GPU, one run each (read them as orders of magnitude).
#   scripts/gpu_bench.sh OUTDIR [BINARY]
# BINARY defaults to target/release/swarmshot (build it where cargo reaches the
# crates, copy it over). Prints and writes OUTDIR/gpu_bench.txt; each batch's
# "wrote … on ADAPTER" line names the adapter it ran on.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:?usage: scripts/gpu_bench.sh OUTDIR [BINARY]}
bin=$(realpath "${2:-target/release/swarmshot}")
mkdir -p "$out"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
export SWARMSHOT_CACHE_DIR="$work/cache"
TIMEFORMAT='  %R s wall, %U s user, %S s sys'

# One batch into a fresh folder: its summary line and its times.
batch() {
    local name=$1
    shift
    echo "== $name"
    { time "$bin" batch "$@" --out "$work/ds" --overwrite 2>&1 | grep -E "^(wrote|error)"; } 2>&1
    rm -rf "$work/ds"
}

{
    nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader 2>/dev/null || echo "no nvidia-smi"
    echo "cores: $(nproc)"
    batch "quickstart.ron, 108 frames (warms the caches)" presets/quickstart.ron
    for makers in 6 12 16; do
        batch "synthswarm_table2.ron, 600 frames, --makers $makers" presets/synthswarm_table2.ron --limit 600 --makers "$makers"
    done
    for makers in 12 16; do
        batch "realistic.ron, 300 frames, --makers $makers" presets/realistic.ron --limit 300 --makers "$makers"
    done
} 2>&1 | tee "$out/gpu_bench.txt"
