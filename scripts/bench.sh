#!/usr/bin/env bash
# The measurements quoted in docs/benchmarks.md and docs/accuracy.md (release build).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
. scripts/env.sh
cargo build --release --locked
bin=./target/release/swarmshot
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
echo "== quickstart batch (108 frames, 1920x1080, MSAA 4, Visible boxes, JPEG q85, YOLO + COCO + manifest)"
$bin batch presets/quickstart.ron --out "$out/quickstart" --timings
echo "== the same preset at 4K (the same 108 frames)"
$bin batch presets/bench/quickstart_4k.ron --out "$out/quickstart4k" --timings
echo "== peer scene (15 Crazyflies, HDR sky, 20 frames)"
$bin batch presets/bench/peer.ron --out "$out/peer" --timings
echo "== render + labels per frame: 15 drones at 1080p (every camera pose; the nearest) and 4K, 1 500 drones, the peer scene"
$bin bench frames
echo "== the peer scene with levels of detail off"
$bin bench frames --peer presets/bench/peer_nolod.ron
echo "== accuracy and frame-time tables"
$bin bench accuracy --plot docs/img/accuracy.png
