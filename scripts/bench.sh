#!/usr/bin/env bash
# The measurements quoted in docs/benchmarks.md and docs/accuracy.md (release build).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
. scripts/env.sh
cargo build --release --locked
bin=./target/release/swarmshot
out=$(mktemp -d)
echo "== quickstart batch (108 frames, 1920x1080, MSAA 4, Visible boxes, JPEG q85)"
$bin batch presets/quickstart.ron --out "$out/quickstart"
echo "== accuracy and frame-time tables"
$bin bench accuracy --plot docs/img/accuracy.png
rm -rf "$out"
