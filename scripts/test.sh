#!/usr/bin/env bash
# Runs every test of the workspace, installing what they need first.
set -euo pipefail
cd "$(dirname "$0")/.."
rustup target add wasm32-wasip2
cargo test --workspace --locked "$@"
