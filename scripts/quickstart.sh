#!/usr/bin/env bash
# Render the quickstart dataset (108 frames, 1920x1080 JPEG + YOLO + COCO) into out/quickstart.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
. scripts/env.sh
cargo build --release --locked
./target/release/swarmshot check presets/quickstart.ron
./target/release/swarmshot batch presets/quickstart.ron --out "${1:-out/quickstart}" --overwrite
