#!/usr/bin/env bash
# The main job: runs the emulator and reports against the f64 reference.
# For now: the demo camera's projections and lens figures, core vs reference.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo run -q --release -p host-sim -- demo
