#!/usr/bin/env bash
# Runs every test of the workspace, installing what they need first: the wasm target for
# the plugins, and Debian's Chromium for the workbench's browser test (tests/workbench.rs).
set -euo pipefail
cd "$(dirname "$0")/.."
rustup target add wasm32-wasip2
if ! command -v chromium >/dev/null; then
    apt-get update && apt-get install -y chromium
fi
cargo test --workspace --locked "$@"
