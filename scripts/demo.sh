#!/usr/bin/env bash
# The main job on a real mesh: the Stanford bunny through a chain of sandboxed services.
# Installs what it needs (the wasm target), builds in release, writes results to demo-out/.
set -euo pipefail
cd "$(dirname "$0")/.."
rustup target add wasm32-wasip2
cargo build --release --locked
mf=target/release/meshflow
out=demo-out
mkdir -p "$out"
input=examples/data/bunny.obj

echo "== input"
"$mf" info "$input"
echo "== services on offer"
"$mf" services
echo "== checks on the input"
for check in vertex-count triangle-count; do
  printf '%-16s %s\n' "$check" "$("$mf" check "$check" "$input")"
done
echo "== laplacian-smoothing, 3 iterations"
"$mf" apply laplacian-smoothing "$input" -o "$out/bunny-smooth.ply" --param iterations=3 --json
echo "== content hashes (same input and parameters give the same hash on every host)"
"$mf" hash "$input"
"$mf" hash "$out/bunny-smooth.ply"
echo "results in $out/"
