#!/usr/bin/env bash
# The whole check: formatting, lints, and every test (rendering tests run on lavapipe).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
. scripts/env.sh
cargo fmt --all -- --check
cargo clippy --locked --all-targets -- -D warnings
cargo test --locked --no-fail-fast
