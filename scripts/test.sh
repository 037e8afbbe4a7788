#!/usr/bin/env bash
# The whole check: formatting, lints, and every test (rendering tests run on lavapipe),
# the Slurm test on a one-node Slurm brought up here, and the headless build.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh slurm-wlm munge ffmpeg
. scripts/env.sh
cargo fmt --all -- --check
cargo clippy --locked --all-targets -- -D warnings
cargo clippy --locked --all-targets --no-default-features -- -D warnings
# The built-in models must pass the Khronos glTF validator (npm's gltf-validator).
if command -v node >/dev/null 2>&1 && command -v npm >/dev/null 2>&1; then
  [ -d tools/node_modules/gltf-validator ] || npm install --silent --no-audit --no-fund --prefix tools gltf-validator@2.0.0-dev.3.10
  node scripts/validate_gltf.mjs
else
  echo "test.sh: node/npm not found; skipping the glTF validator (install nodejs npm to run it)" >&2
fi
# A one-node Slurm (munged, slurmctld, slurmd) for tests/slurm.rs; here the Slurm test
# must run, so a Slurm that does not come up fails the check.
slurm_env=$(scripts/slurm_local.sh)   # (an assignment, so its failure stops the check)
eval "$slurm_env"
trap 'scripts/slurm_local.sh stop' EXIT
export SWARMSHOT_REQUIRE_SLURM=1
# fit from a video needs ffmpeg and ffprobe (tests/suite/fit_video.rs); installed above.
export SWARMSHOT_REQUIRE_FFMPEG=1
# The library, binaries and tests (the examples are compiled by clippy above; linking
# twelve benchmark binaries here would only cost CI time; the crate has no doctests).
cargo test --locked --no-fail-fast --lib --bins --tests
# The headless CLI (no egui, eframe, winit, rfd, zbus, open; docs/scale.md): clippy has compiled
# and linted it above (--no-default-features); its dependency tree must hold none of the app's crates.
if cargo tree --locked --no-default-features -e normal | grep -E 'egui|eframe|winit|rfd|zbus| open v'; then
  echo "test.sh: the headless build (--no-default-features) pulls in the crates above" >&2
  exit 1
fi
