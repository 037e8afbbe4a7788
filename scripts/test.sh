#!/usr/bin/env bash
# The whole check: formatting, lints, and every test (rendering tests run on lavapipe).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
. scripts/env.sh
cargo fmt --all -- --check
cargo clippy --locked --all-targets -- -D warnings
# The built-in models must pass the Khronos glTF validator (npm's gltf-validator).
if command -v node >/dev/null 2>&1 && command -v npm >/dev/null 2>&1; then
  [ -d tools/node_modules/gltf-validator ] || npm install --silent --no-audit --no-fund --prefix tools gltf-validator@2.0.0-dev.3.10
  node scripts/validate_gltf.mjs
else
  echo "test.sh: node/npm not found; skipping the glTF validator (install nodejs npm to run it)" >&2
fi
cargo test --locked --no-fail-fast
