#!/usr/bin/env bash
# The main job: renders every shipped scene with the fixed-point core and the
# f64 reference, writes the frames, diff maps and metrics under out/, and
# prints one line of metrics a scene; streams the standard scene through the
# simulated UART and USB links and runs the fault campaign; then the demo
# camera's projections and lens figures, core vs reference.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build -q --release -p host-sim
for scene in scenes/*.toml; do
  name=$(basename "$scene" .toml)
  ./target/release/host-sim render --scene "$scene" --out "out/$name"
done
echo "frames, diff maps and metrics.json: out/<scene>/"
echo
# The link: the standard scene streamed through the simulated links, then the
# standard fault campaign.
./target/release/host-sim stream --scene scenes/standard.toml --link uart:921600 --frames 20 --out out/stream-uart
./target/release/host-sim stream --scene scenes/standard.toml --link usb-fs --frames 200 --out out/stream-usb
./target/release/host-sim faults --out out/faults 2>/dev/null
echo
./target/release/host-sim demo
