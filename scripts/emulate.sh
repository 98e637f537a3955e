#!/usr/bin/env bash
# The main job: renders every shipped scene with the fixed-point core and the
# f64 reference, writes the frames, diff maps and metrics under out/, and
# prints one line of metrics a scene; then the demo camera's projections and
# lens figures, core vs reference.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build -q --release -p host-sim
for scene in scenes/*.toml; do
  name=$(basename "$scene" .toml)
  ./target/release/host-sim render --scene "$scene" --out "out/$name"
done
echo "frames, diff maps and metrics.json: out/<scene>/"
echo
./target/release/host-sim demo
