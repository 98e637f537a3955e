#!/usr/bin/env bash
# The main job: renders every shipped scene with the fixed-point core and the
# f64 reference, writes the frames, diff maps and metrics under out/, and
# prints one line of metrics a scene; streams the standard scene through the
# simulated UART and USB links and runs the fault campaign; runs the firmware
# in QEMU on both boards (installing QEMU when it can) and checks its frames
# against the host render; drives the camera firmware in QEMU along a
# trajectory (the closed loop); the speed/accuracy sweep; then the demo camera's
# projections and lens figures, core vs reference.
#
# Works on a fresh machine with only rustup (it installs the thumb targets).
# --short: fewer streamed frames and the sweep's tiny configuration (what the
# test command runs, so that CI exercises this script).
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/lib.sh
short=0
[ "${1:-}" = "--short" ] && short=1
ensure_toolchain
# host-sim's release build, or a host-sim the caller built (HILCAM_HOST_SIM:
# the test command gives the one its tests ran, built at the test profile;
# the same frames and instruction counts, only its host timings slower).
if [ -n "${HILCAM_HOST_SIM:-}" ]; then
  host_sim=$HILCAM_HOST_SIM
else
  cargo build -q --release -p host-sim
  host_sim=./target/release/host-sim
fi
for scene in scenes/*.toml; do
  name=$(basename "$scene" .toml)
  "$host_sim" render --scene "$scene" --out "out/$name"
done
echo "frames, diff maps and metrics.json: out/<scene>/"
echo
# The link: the standard scene streamed through the simulated links, then the
# standard fault campaign.
uart_frames=20 usb_frames=200
[ $short = 1 ] && uart_frames=3 usb_frames=20
"$host_sim" stream --scene scenes/standard.toml --link uart:921600 --frames $uart_frames --out out/stream-uart
"$host_sim" stream --scene scenes/standard.toml --link usb-fs --frames $usb_frames --out out/stream-usb
"$host_sim" faults --out out/faults 2>/dev/null
echo
# The sensor as calibration software sees it: OpenCV's corners and
# calibrateCamera on the 36-frame calibration set (pixel-area integration by
# default) against the true corners (docs/sensor.md). Installs
# opencv-python-headless and numpy with pip when they are missing.
python3 scripts/opencv-check.py --host-sim "$host_sim" --out out/opencv
# The ground-truth export (host-sim export: OpenCV and ROS YAML), loaded by
# OpenCV and checked with cv2.projectPoints on every shipped camera.
python3 scripts/export-check.py --host-sim "$host_sim" --out out/export
echo
# The firmware in QEMU: the same scenes rendered on a Cortex-M3 and a
# Cortex-M4F, streamed over their UARTs, checked byte for byte.
qemu=0
ensure_qemu && qemu=1
if [ $qemu = 1 ]; then
  build_firmware
  "$host_sim" hil --board lm3s6965evb --elf firmware/target/thumbv7m-none-eabi/release/hilcam-firmware --out out/hil/lm3s6965evb
  "$host_sim" hil --board mps2-an386 --elf firmware/target/thumbv7em-none-eabihf/release/hilcam-firmware --out out/hil/mps2-an386
  # The Cortex-M0 with 16 KiB of RAM (QEMU microbit, nRF51 UART).
  "$host_sim" hil --board microbit --elf firmware/target/thumbv6m-none-eabi/release/hilcam-firmware --out out/hil/microbit
  # The closed loop: the camera build of the firmware driven over its UART
  # (LoadScene: the scene as data; then SetPose, Trigger) along a
  # trajectory, every frame checked byte for byte against the host render
  # of its pose and its ground truth against the pose sent.
  loop_frames=300
  [ $short = 1 ] && loop_frames=30
  "$host_sim" drive --board lm3s6965evb --scene scenes/standard.toml --frames $loop_frames \
    --capture out/drive/camera.bin --out out/drive
  # A scene the firmware was not built with (the standard scene in RGB565,
  # a sphere moved and coloured, a lens whose fold lies inside the sensor:
  # pixels outside the lens field, flagged on the wire): sent as data,
  # driven the same way.
  mkdir -p out/drive-new
  sed -e 's/^name = "standard"/name = "not-shipped"/' -e 's/^format = "gray8"/format = "rgb565"/' \
      -e 's/^distortion = \[0.15, 0.05\]/distortion = [-2.0, 0.0]/' \
      -e 's/^albedo = 0.8$/albedo = [0.8, 0.5, 0.3]/' \
      -e 's/^centre = \[-0.5, 0.4, 0.3\]/centre = [-0.3, 0.5, 0.6]/' scenes/standard.toml > out/drive-new/scene.toml
  cmp -s scenes/standard.toml out/drive-new/scene.toml && { echo "the edits changed nothing"; exit 1; }
  "$host_sim" drive --board lm3s6965evb --scene out/drive-new/scene.toml --frames 10 \
    --out out/drive-new/frames
else
  echo "SKIPPED: the firmware-in-QEMU run (qemu-system-arm is not installed and could not be"
  echo "installed: run as root on Debian, or apt-get install qemu-system-arm, then rerun)."
  echo "Everything above ran on the host only."
fi
echo
# The speed/accuracy trade: every variant against the reference, on the M3
# and the M4F when QEMU is here (the host only otherwise).
sweep=()
[ $short = 1 ] && sweep=(--tiny --repeats 1)
[ $qemu = 1 ] || sweep+=(--boards none)
"$host_sim" tradeoff "${sweep[@]}" --out out/tradeoff | { sed -n '/^Cheapest/,$p' | grep -v '^| standard-' || true; }
if grep -q '"bit_exact_m3": false\|"bit_exact_m4f": false' out/tradeoff/tradeoff.json; then
  echo "a variant was not bit-exact on a board"
  exit 1
fi
echo "the whole table and the plot: out/tradeoff/tradeoff.md, out/tradeoff/tradeoff.png"
echo
"$host_sim" demo
