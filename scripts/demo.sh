#!/usr/bin/env bash
# The main job: real workflows on real meshes through the embedded default — an engine and
# three hosts on loopback, talking HTTP, shipping corrections between hosts. Installs what it
# needs (the wasm target), builds in release, writes meshes and run records to demo-out/.
set -euo pipefail
cd "$(dirname "$0")/.."
rustup target add wasm32-wasip2
cargo build --release --locked
mf=target/release/meshflow
out=demo-out
mkdir -p "$out"

echo "== a scan-like mesh: 200k vertices, 60 spurious pieces, 50 holes, noise"
"$mf" generate scan --vertices 200000 --components 60 --holes 50 --noise 0.2 --seed 7 -o "$out/scan.ply"
"$mf" info "$out/scan.ply"

for transfer in auto full; do
  echo "== repair (RSC -> LS -> HF -> RDT) on 3 hosts, transfer: $transfer"
  "$mf" run examples/workflows/repair.json "$out/scan.ply" -o "$out/scan-repaired-$transfer.ply" \
    --transfer "$transfer" --report "$out/repair-$transfer.json"
done
echo "== both transfers give the same mesh"
"$mf" hash "$out/scan-repaired-auto.ply"
"$mf" hash "$out/scan-repaired-full.ply"
for check in component-count hole-count is-manifold; do
  printf '%-16s %s -> %s\n' "$check" "$("$mf" check "$check" "$out/scan.ply")" \
    "$("$mf" check "$check" "$out/scan-repaired-auto.ply")"
done

echo "== the Stanford bunny: WHILE normal-instability > 10 DO laplacian-smoothing, after noise"
"$mf" run examples/workflows/smooth-while-unstable.json examples/data/bunny.obj \
  -o "$out/bunny-smoothed.ply" --report "$out/bunny-while.json"
echo "== IF is-manifold THEN fill holes and smooth ELSE clean up"
"$mf" run examples/workflows/branch-on-manifold.json examples/data/bunny.obj \
  -o "$out/bunny-branch.ply" --report "$out/bunny-if.json"
echo "results and run records in $out/"
