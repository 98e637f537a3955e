#!/usr/bin/env bash
# The main job: renders every shipped scene with the fixed-point core and the
# f64 reference, writes the frames, diff maps and metrics under out/, and
# prints one line of metrics a scene; streams the standard scene through the
# simulated UART and USB links and runs the fault campaign; runs the firmware
# in QEMU on both boards (installing QEMU when it can) and checks its frames
# against the host render; then the demo camera's projections and lens
# figures, core vs reference.
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/lib.sh
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
# The firmware in QEMU: the same scenes rendered on a Cortex-M3 and a
# Cortex-M4F, streamed over their UARTs, checked byte for byte.
if ensure_qemu; then
  build_firmware
  ./target/release/host-sim hil --board lm3s6965evb --elf firmware/target/thumbv7m-none-eabi/release/hilcam-firmware --out out/hil/lm3s6965evb
  ./target/release/host-sim hil --board mps2-an386 --elf firmware/target/thumbv7em-none-eabihf/release/hilcam-firmware --out out/hil/mps2-an386
else
  echo "SKIPPED: the firmware-in-QEMU run (qemu-system-arm is not installed and could not be"
  echo "installed: run as root on Debian, or apt-get install qemu-system-arm, then rerun)."
  echo "Everything above ran on the host only."
fi
echo
# The speed/accuracy trade: every variant against the reference, on the M3
# and the M4F when QEMU is here (the host only otherwise).
if ensure_qemu; then
  ./target/release/host-sim tradeoff --out out/tradeoff | sed -n '/^Cheapest/,$p' | grep -v '^| standard-'
else
  ./target/release/host-sim tradeoff --boards none --out out/tradeoff | sed -n '/^Cheapest/,$p'
fi
echo "the whole table and the plot: out/tradeoff/tradeoff.md, out/tradeoff/tradeoff.png"
echo
./target/release/host-sim demo
