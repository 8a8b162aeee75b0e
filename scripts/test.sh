#!/usr/bin/env bash
# Runs every test of the workspace, installing what they need first: the wasm target for
# the plugins, Debian's Chromium for the workbench's browser test (tests/workbench.rs), and
# Debian's clang for wasm32-wasi, with which tests/cpp_template.rs builds the C++ template
# (and its native libc++ and sanitizers, with which tests/cpp_native.rs runs `make test`),
# and a Python venv (target/python-venv) for the Python client's tests (python/tests).
set -euo pipefail
cd "$(dirname "$0")/.."
rustup target add wasm32-wasip2
packages=(chromium make clang-19 lld-19 wasi-libc libc++-19-dev-wasm32 libclang-rt-19-dev-wasm32
    libc++-19-dev libc++abi-19-dev libclang-rt-19-dev)
missing=()
for package in "${packages[@]}"; do
    dpkg -s "$package" >/dev/null 2>&1 || missing+=("$package")
done
if ((${#missing[@]})); then
    apt-get update && apt-get install -y "${missing[@]}"
fi
cargo test --workspace --locked "$@"

# The Python client (python/) against `meshflow up`, in a venv under target/; the Python
# plugin template built with componentize-py (PyPI) into target/ by its Makefile, in a
# venv of its own there (target/python-venv-plugin).
command -v python3 >/dev/null || { apt-get update && apt-get install -y python3; }
venv=target/python-venv
if [[ ! -x $venv/bin/python ]]; then
    python3 -m venv "$venv" 2>/dev/null || {
        rm -rf "$venv"
        apt-get update && apt-get install -y python3-venv
        python3 -m venv "$venv"
    }
fi
"$venv/bin/pip" install --quiet --disable-pip-version-check -e 'python[test]'
# `cargo test` built the binary the tests run; building it alone would unify other
# features and compile wasmtime once more.
[[ -x target/debug/meshflow ]] || cargo build --locked --bin meshflow
MESHFLOW_BIN="${MESHFLOW_BIN:-$PWD/target/debug/meshflow}" "$venv/bin/python" -m pytest -q python/tests
