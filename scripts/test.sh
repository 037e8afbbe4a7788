#!/usr/bin/env bash
# The whole check: formatting, lints, and every test (rendering tests run on lavapipe),
# the Slurm test on a one-node Slurm brought up here, and the headless build.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh slurm-wlm munge ffmpeg
. scripts/env.sh
cargo fmt --all -- --check
# Lints and the test build in one pass: clippy-driver compiles our crate's targets (cargo runs
# it in place of rustc for the workspace only, as `cargo clippy` does, with its `-D warnings`),
# so the dependencies are compiled once, for the tests, instead of also being checked for a
# separate `cargo clippy --all-targets` (docs/benchmarks.md, "The test build").
# clippy-driver beside cargo-clippy, where `cargo clippy` finds it.
export RUSTC_WORKSPACE_WRAPPER="$(dirname "$(command -v cargo-clippy)")/clippy-driver"
export CLIPPY_ARGS="-D__CLIPPY_HACKERY__warnings__CLIPPY_HACKERY__"
# The wrapper must deny what clippy warns of: a file whose one fault is a clippy warning (a
# `vec!` that could be an array) compiles without CLIPPY_ARGS and fails with it, or the pass
# below would let warnings through.
canary=$(mktemp -d)
printf 'fn main() { let v = vec![1]; println!("{}", v.len()); }\n' > "$canary/canary.rs"
compile_canary() {
  "$RUSTC_WORKSPACE_WRAPPER" rustc "$canary/canary.rs" --edition 2024 --emit=metadata \
    -o "$canary/canary.rmeta" 2>/dev/null
}
if ! CLIPPY_ARGS= compile_canary || compile_canary; then
  echo "test.sh: clippy-driver does not deny clippy's warnings through CLIPPY_ARGS" >&2
  exit 1
fi
rm -rf "$canary"
cargo test --locked --no-run --all-targets
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
# The library, binaries and tests, as built above (the crate has no doctests).
cargo test --locked --no-fail-fast --lib --bins --tests
# The headless CLI (no egui, eframe, winit, rfd, zbus, open; docs/scale.md): clippy has compiled
# and linted it above (--no-default-features); its dependency tree must hold none of the app's crates.
if cargo tree --locked --no-default-features -e normal | grep -E 'egui|eframe|winit|rfd|zbus| open v'; then
  echo "test.sh: the headless build (--no-default-features) pulls in the crates above" >&2
  exit 1
fi
