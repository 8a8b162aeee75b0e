#!/usr/bin/env bash
# Runs every test of the workspace, installing what they need first: the wasm target for
# the plugins, Debian's Chromium for the workbench's browser test (tests/workbench.rs), and
# Debian's clang for wasm32-wasi, with which tests/cpp_template.rs builds the C++ template.
set -euo pipefail
cd "$(dirname "$0")/.."
rustup target add wasm32-wasip2
packages=(chromium make clang-19 lld-19 wasi-libc libc++-19-dev-wasm32 libclang-rt-19-dev-wasm32)
missing=()
for package in "${packages[@]}"; do
    dpkg -s "$package" >/dev/null 2>&1 || missing+=("$package")
done
if ((${#missing[@]})); then
    apt-get update && apt-get install -y "${missing[@]}"
fi
cargo test --workspace --locked "$@"
