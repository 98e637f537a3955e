#!/usr/bin/env bash
# The main job: the emulator end to end, a line a stage with its time.
#
#   render    every shipped scene with the fixed-point core and the f64
#             reference: frame, reference, diff map, metrics (out/<scene>/)
#   link      the standard scene over the simulated UART and USB links, and
#             the fault campaign (out/stream-uart, out/stream-usb, out/faults)
#   opencv    OpenCV's calibration on the rendered calibration set, and the
#             ground-truth export checked with cv2.projectPoints (a Python
#             virtual environment in target/venv; out/opencv, out/export)
#   firmware  the firmware on every board of firmware/boards.toml in QEMU,
#             every frame checked byte for byte against the host render
#             (out/hil/<board>/)
#   drive     the camera firmware driven over its UART along a trajectory,
#             and sent a scene it was not built with (out/drive, out/drive-new)
#   sweep     the speed/accuracy trade, every variant against the reference
#             (out/tradeoff)
#
# Works on a fresh machine with only rustup: it installs the thumb targets,
# QEMU (as root, with apt) and the Python packages (in target/venv).
# Without QEMU it says so and runs the host-only stages.
#
#   --full    the whole sweep, 300 poses, 200 frames a link, the fault
#             campaign at full scale, the 1080p throughput; then
#             docs/measurements.md from these outputs
#             (scripts/measurements.py)
#   --short   what the test command runs: host-sim as the tests built it
#             (HILCAM_HOST_SIM), otherwise as the default
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/lib.sh
mode=default
case "${1:-}" in
  --full) mode=full ;;
  --short) mode=short ;;
  "") ;;
  *) echo "usage: $0 [--full | --short]" >&2; exit 2 ;;
esac
start=$(date +%s.%N)
mkdir -p out
: > out/run.tsv

# stage NAME COMMAND...: runs COMMAND, its output indented, then one line
# with the stage's time; the time and the command go to out/run.tsv.
stage() {
  local name=$1 t0 t1
  shift
  t0=$(date +%s.%N)
  echo "== $name"
  if "$@" 2>&1 | sed 's/^/   /'; then :; else
    echo "FAILED: $name ($*)" >&2
    exit 1
  fi
  t1=$(date +%s.%N)
  printf '%s\t%.1f\t%s\n' "$name" "$(awk "BEGIN { print $t1 - $t0 }")" "$*" >> out/run.tsv
  printf '   %s: %.1f s\n' "$name" "$(awk "BEGIN { print $t1 - $t0 }")"
}

stage toolchain ensure_toolchain
# QEMU (apt, as root, where it is missing) and the Python environment
# (pip) install in the background while host-sim builds.
ensure_qemu > out/qemu-install.log 2>&1 &
qemu_install=$!
ensure_venv > out/venv-install.log 2>&1 &
venv_install=$!
trap 'kill "$qemu_install" "$venv_install" 2>/dev/null || true' EXIT

# host-sim: the one the caller built (HILCAM_HOST_SIM); with --full the
# release build (whose host timings docs/measurements.md quotes); else the
# main job's quick build (the release profile's optimisation without its
# single codegen unit and LTO, and the fast loops for the baseline x86-64
# only: the same frames and counts, built in half the time).
if [ -n "${HILCAM_HOST_SIM:-}" ]; then
  host_sim=$HILCAM_HOST_SIM
elif [ $mode = full ]; then
  stage build cargo build -q --release -p host-sim
  host_sim=./target/release/host-sim
else
  stage build cargo build -q --profile main-job -p host-sim --no-default-features --features cli
  host_sim=./target/main-job/host-sim
fi

render_all() {
  for scene in scenes/*.toml; do
    "$host_sim" render --scene "$scene" --out "out/$(basename "$scene" .toml)" | sed -n 1p
  done
}
stage render render_all

frames_uart=3 frames_usb=20 scale=0.1
[ $mode = full ] && frames_uart=20 frames_usb=200 scale=1
link_all() {
  "$host_sim" stream --scene scenes/standard.toml --link uart:921600 --frames $frames_uart --out out/stream-uart
  "$host_sim" stream --scene scenes/standard.toml --link usb-fs --frames $frames_usb --out out/stream-usb
  "$host_sim" faults --scale $scale --out out/faults 2>/dev/null
}
stage link link_all

opencv_all() {
  target/venv/bin/python scripts/opencv-check.py --out out/opencv
  target/venv/bin/python scripts/export-check.py --host-sim "$host_sim" --out out/export
}
wait "$venv_install" || { cat out/venv-install.log; echo "the Python environment (target/venv) could not be made" >&2; exit 1; }
stage opencv opencv_all

qemu=0
wait "$qemu_install" && qemu=1
if [ $qemu = 1 ]; then
  firmware_all() {
    for board in $(sed -n 's/^name = "\(.*\)"/\1/p' firmware/boards.toml); do
      "$host_sim" hil --board "$board" --out "out/hil/$board" | tail -1
    done
  }
  stage firmware firmware_all
  poses=30
  [ $mode = full ] && poses=300
  drive_all() {
    # (The driven camera holds no cast shadows: boards.toml camera_features.
    # It is sent the standard scene with environment.shadows off.)
    mkdir -p out/drive
    sed 's/^\[environment\]$/[environment]\nshadows = false/' scenes/standard.toml > out/drive/scene.toml
    "$host_sim" drive --board lm3s6965evb --scene out/drive/scene.toml --frames $poses \
      --capture out/drive/camera.bin --out out/drive | tail -1
    # A scene the firmware was not built with (the standard scene in
    # RGB565, a sphere moved and coloured, a lens whose fold lies inside
    # the sensor: pixels outside the lens field, flagged on the wire), sent
    # as data and driven the same way.
    mkdir -p out/drive-new
    sed -e 's/^name = "standard"/name = "not-shipped"/' -e 's/^format = "gray8"/format = "rgb565"/' \
        -e 's/^distortion = \[0.15, 0.05\]/distortion = [-2.0, 0.0]/' \
        -e 's/^albedo = 0.8$/albedo = [0.8, 0.5, 0.3]/' \
        -e 's/^centre = \[-0.5, 0.4, 0.3\]/centre = [-0.3, 0.5, 0.6]/' out/drive/scene.toml > out/drive-new/scene.toml
    cmp -s out/drive/scene.toml out/drive-new/scene.toml && { echo "the edits changed nothing"; return 1; }
    "$host_sim" drive --board lm3s6965evb --scene out/drive-new/scene.toml --frames 10 --out out/drive-new/frames | tail -1
  }
  stage drive drive_all
else
  echo "== firmware, drive: SKIPPED (qemu-system-arm is missing and could not be installed:"
  echo "   run as root on Debian, or apt-get install qemu-system-arm; out/qemu-install.log)"
fi

sweep=(--tiny --repeats 1)
[ $mode = full ] && sweep=()
[ $qemu = 1 ] || sweep+=(--boards none)
sweep_all() {
  "$host_sim" tradeoff "${sweep[@]}" --out out/tradeoff | sed -n '/^Cheapest/,$p' | grep -v '^| standard-' || true
  if grep -q '"bit_exact_m3": false\|"bit_exact_m4f": false' out/tradeoff/tradeoff.json; then
    echo "a variant was not bit-exact on a board"
    return 1
  fi
}
stage sweep sweep_all

if [ $mode = full ]; then
  throughput() {
    mkdir -p out/throughput
    sed -e 's/^width = 160/width = 1920/' -e 's/^height = 120/height = 1080/' -e 's/^pitch = 12e-6/pitch = 1e-6/' \
        -e 's/^tolerable_blur = 12e-6/tolerable_blur = 1e-6/' scenes/standard.toml > out/throughput/standard-1080p.toml
    "$host_sim" throughput --scene out/throughput/standard-1080p.toml --frames 20 --out out/throughput
  }
  stage throughput throughput
  stage python-loop target/venv/bin/python scripts/python-loop.py --host-sim "$host_sim" --out out/python-loop
  stage measurements python3 scripts/measurements.py --out out --write docs/measurements.md
fi

end=$(date +%s.%N)
echo
printf 'main job: %.0f s in all; the stages above, each with its time (out/run.tsv)\n' "$(awk "BEGIN { print $end - $start }")"
echo "  out/<scene>/             frame.png, reference.png, diff.png, metrics.json (one a shipped scene)"
echo "  out/stream-*/, out/faults/  the links: stream.json, received.png, faults.json"
echo "  out/opencv/, out/export/ OpenCV's calibration and the export's check"
[ $qemu = 1 ] && echo "  out/hil/<board>/         each board's frames and hil.json (instructions, flash, RAM); out/drive*/ the closed loop"
echo "  out/tradeoff/            tradeoff.md, tradeoff.png: the speed/accuracy trade"
[ $mode = full ] && echo "  docs/measurements.md     every figure above, regenerated"
exit 0
