#!/usr/bin/env bash
# Runs every check and test of hilcam. Works on a fresh machine with only
# rustup: it installs the thumb targets and components it needs.
set -euo pipefail
cd "$(dirname "$0")/.."
. scripts/lib.sh

echo "== toolchain: the thumb targets and components (scripts/lib.sh ensure_toolchain)"
ensure_toolchain
rustc --version
# A run fills about 3 GB here (target/: the workspace, the three firmware
# builds, the fuzz targets); a full disk shows up later as a compiler's
# "No space left on device" (CI on 2026-12-05, a disk others had filled).
free_kb=$(df -Pk . | awk 'NR == 2 { print $4 }')
echo "== disk: $((free_kb / 1048576)) GiB free in $(pwd) (a run writes about 3 GB)"
if [ "$free_kb" -lt 3500000 ]; then
  echo "warning: under 3.5 GB free; the builds below may fail for want of disk" >&2
fi

# QEMU where it is missing, in the background while the checks below run.
mkdir -p target
ensure_qemu > target/qemu-install.log 2>&1 &
qemu_install=$!
# Stopped if a check below fails first (after a success it has ended).
trap 'kill "$qemu_install" 2>/dev/null || true' EXIT

# The firmware builds beside the checks, the tests' build and run: each
# board's build ends in one LTO codegen unit on one core, and the checks
# below (clippy of one crate, the docs, the thumb lints, one after another)
# and the tests leave a core idle at times.
echo "== firmware builds: every board of firmware/boards.toml, and their clippy; in the background"
(for b in $(boards); do build_firmware "$b" || exit 1; done &&
  cd firmware && cargo clippy -q --release --target thumbv7m-none-eabi -- -D warnings &&
  cargo clippy -q --release --no-default-features --features camera,mix32,sensor \
    --target thumbv7m-none-eabi -- -D warnings) > target/firmware-build.log 2>&1 &
firmware_build=$!
# The fuzz targets' build (nightly, the address sanitizer; on a fresh
# machine nightly and cargo-fuzz installed first) from here on, niced: it
# takes the cycles the checks, the tests, the main job and the QEMU runs
# below leave (they wait on single-unit links and on QEMU much of the
# time). Started after the main job instead, it ended 155 s after
# everything else (2026-12-03). The targets run at the end, on idle cores.
nice -n 19 ./scripts/fuzz.sh --build > target/fuzz-build.log 2>&1 &
fuzz_build=$!
# The Python environment with the hilcam package built from this tree.
ensure_venv > target/venv-install.log 2>&1 &
venv_install=$!
trap 'kill "$qemu_install" "$firmware_build" "$fuzz_build" "$venv_install" 2>/dev/null || true' EXIT

echo "== format"
cargo fmt --all -- --check
cargo fmt --manifest-path python/Cargo.toml -- --check

echo "== layout: no file over 1 000 lines or function over 150, no import circle (scripts/check-layout.py)"
python3 scripts/check-layout.py

echo "== clippy: workspace, warnings are errors (and host-sim without its cli feature, as the fuzz targets use it)"
cargo clippy --workspace --all-targets -q -- -D warnings
cargo clippy -p host-sim --no-default-features --lib -q -- -D warnings
# The core without its optional stages (a size build's features), each alone.
for features in "" mix32 sensor; do
  cargo clippy --lib --no-default-features --features "$features" -q -- -D warnings
done

echo "== the core's API docs: no warning (a broken link, or a public doc linking a private item)"
RUSTDOCFLAGS="-D warnings" cargo doc -q --no-deps -p hilcam

echo "== clippy: core on thumbv7m with the panic-free lints"
cargo clippy --lib --target thumbv7m-none-eabi -q -- -D warnings \
  -D clippy::unwrap_used -D clippy::expect_used -D clippy::panic -D clippy::indexing_slicing

echo "== the core's defmt feature on the Cortex-M4F: clippy, warnings are errors"
# Checked, not built: the firmware builds (in the background, above)
# compile the core for the three thumb targets with its default features (mix32 and sensor; the
# size build at the end with none), and a library build with defmt added
# only the machine code of a library no binary links (a release build,
# 41-44 s of this command on one core, 2026-12-03; a check compiles
# everything a type or a constant can reject).
cargo clippy -q --lib --target thumbv7em-none-eabihf --features defmt -- -D warnings
echo "   thumbv7em-none-eabihf --features defmt: ok"

echo "== tests"
rm -rf target/tmp/accuracy
cargo test --workspace

echo "== the Python package: clippy, and its tests against host-sim frame and host-sim camera over a pty"
wait "$venv_install" || { cat target/venv-install.log; echo "the Python environment (target/venv) could not be made"; exit 1; }
(cd python && CARGO_TARGET_DIR=../target/python cargo clippy -q -- -D warnings)
HILCAM_HOST_SIM="$PWD/target/debug/host-sim" target/venv/bin/python -m pytest -q python/tests

echo "== firmware builds and their clippy (above)"
wait "$firmware_build" || { cat target/firmware-build.log; echo "a firmware build or its clippy failed"; exit 1; }
cat target/firmware-build.log
echo "   $(boards | tr '\n' ' '); clippy of the default firmware and the driven camera: ok"
# An ELF built for one board, given to hil for another: refused naming
# both, before QEMU runs it (it would run silent until the timeout).
if target/debug/host-sim hil --board mps2-an505 --elf firmware/target/thumbv7m-none-eabi/release/hilcam-firmware \
  --out target/hil/wrong-board > target/hil-wrong-board.log 2>&1 ||
  ! grep -q "built for board lm3s6965evb, not --board mps2-an505" target/hil-wrong-board.log; then
  cat target/hil-wrong-board.log; echo "hil ran an ELF built for another board"; exit 1
fi
echo "   an M3 ELF given to hil --board mps2-an505: refused naming both boards"

echo "== the main job, short (README's first command): renders, links, OpenCV, every board in QEMU, the drive, tiny sweep"
# host-sim as the tests above built and ran it (the test profile,
# opt-level 1): the main job's frames, comparisons and QEMU counts do not
# depend on host-sim's optimisation, and its release build (LTO in one
# codegen unit) cost this command about 5 minutes (2026-12-03). The
# README's main-job command builds and runs the release binary.
export HILCAM_HOST_SIM="$PWD/target/debug/host-sim"
[ -x "$HILCAM_HOST_SIM" ] || { echo "$HILCAM_HOST_SIM: not built by the tests"; exit 1; }
wait "$qemu_install" || { cat target/qemu-install.log; echo "qemu-system-arm is missing and could not be installed"; exit 1; }
./scripts/emulate.sh --short

echo "== firmware in QEMU at 640x480 on every board (the standard scene, wider): streams by lines, RAM O(width)"
mkdir -p target/scenes640
sed -e 's/^name = "standard"/name = "standard-640"/' -e 's/^width = 160/width = 640/' \
    -e 's/^height = 120/height = 480/' -e 's/^pitch = 12e-6/pitch = 3e-6/' \
    -e 's/^tolerable_blur = 12e-6/tolerable_blur = 3e-6/' scenes/standard.toml > target/scenes640/standard-640.toml
# (The driven camera, which holds no cast shadows, is sent the same frame without them.)
mkdir -p target/scenes-unshadowed
sed 's/^\[environment\]$/[environment]\nshadows = false/' target/scenes640/standard-640.toml > target/scenes-unshadowed/standard-640.toml
for b in $(boards); do
  "$HILCAM_HOST_SIM" hil --board "$b" --scene target/scenes640/standard-640.toml --out "target/hil/$b-640" | tail -1
done
# The driven camera, sent the 640x480 scene as data: its RAM with the widest lines it takes;
# and the driven camera on the M0 (built for size there: host-sim's build_firmware_as).
# Driven cameras hold no cast shadows (their flash): sent the scenes with
# environment.shadows off.
"$HILCAM_HOST_SIM" drive --board lm3s6965evb --scene target/scenes-unshadowed/standard-640.toml --frames 3 \
  --out target/drive-640 | tail -1
for s in standard shallow-dof; do
  sed 's/^\[environment\]$/[environment]\nshadows = false/' "scenes/$s.toml" > "target/scenes-unshadowed/$s.toml"
done
"$HILCAM_HOST_SIM" drive --board microbit --scene target/scenes-unshadowed/standard.toml --frames 3 \
  --out target/drive-microbit | tail -1
# The M0's driven camera sent the defocused scene: the aperture loop's
# frames on its render path (it overflowed 16 KiB before ChunkBufs::EMPTY,
# QEMU's lockup closing the link).
"$HILCAM_HOST_SIM" drive --board microbit --scene target/scenes-unshadowed/shallow-dof.toml --frames 1 \
  --out target/drive-microbit-dof | tail -1

echo "== a pose and its trigger sent at once: the camera plans before it answers the trigger (round trips within 1 %)"
# The camera plans again after a change of pose (soft-float f64; the
# batched drive prints it as the pose's cost). A trigger read in the same batch as its pose
# is answered after that plan, so its round trip (answer to frame) is the
# same however the host's writes are split. Before, it held the plan when
# the host was loaded (20 frames --batched beside six busy loops on 2
# cores: a mean of 738 932 instructions, against 180 159 since).
"$HILCAM_HOST_SIM" drive --board lm3s6965evb --scene target/scenes-unshadowed/standard.toml --frames 3 \
  --out target/drive-seq | tail -1
"$HILCAM_HOST_SIM" drive --board lm3s6965evb --scene target/scenes-unshadowed/standard.toml --frames 3 --batched \
  --out target/drive-batched | tail -1
rt() { awk '/"round_trip_instructions"/ { getline; gsub("[ ,]", ""); print; exit }' "$1"; }
awk -v a="$(rt target/drive-seq/drive.json)" -v b="$(rt target/drive-batched/drive.json)" \
  'BEGIN { printf "mean round trip: %.0f instructions after the pose'"'"'s answer, %.0f sent at once\n", a, b; exit !(a > 0 && b > 0 && b < 1.01 * a && a < 1.01 * b) }' ||
  { echo "a trigger sent with its pose waited for the planner (or a round trip was not measured)"; exit 1; }

echo "== where the instructions go: the standard scene's stages on the M3 and the M0 (host-sim profile; fails if the trace misses the -icount frame cost by over 1 %)"
"$HILCAM_HOST_SIM" profile --board lm3s6965evb --out target/profile/lm3s6965evb | tail -n 20
"$HILCAM_HOST_SIM" profile --board microbit --out target/profile/microbit | tail -n 20

echo "== peak RAM (painted stack + static) within 16 KiB on every board, at 160x120 and 640x480, and in the driven camera"
for j in $(for b in $(boards); do echo "out/hil/$b/hil.json target/hil/$b-640/hil.json"; done) \
  out/drive/drive.json out/drive-new/frames/drive.json target/drive-640/drive.json target/drive-microbit/drive.json \
  target/drive-microbit-dof/drive.json; do
  awk -F': ' -v f="$j" '/"ram_peak_bytes"/ { found = 1; gsub(",", "", $2); print f ": peak RAM " $2 " B"; if ($2 + 0 > 16384 || $2 + 0 == 0) bad = 1 } END { exit bad || !found }' "$j" ||
    { echo "$j: peak RAM over 16 KiB (or not measured)"; exit 1; }
done

echo "== no panic path in the default firmware (no core::panicking symbol in the ELF) on every board, nor in the driven camera (M3, M0)"
# The driven camera decodes commands and loads scenes from the link. The
# M0's is built at opt-level z with a higher inline threshold, which
# inlines postcard's varint encoding (host-sim's Board::rustflags).
for j in $(for b in $(boards); do echo "out/hil/$b/hil.json"; done) \
  out/drive/drive.json target/drive-640/drive.json target/drive-microbit/drive.json; do
  grep -q '"panic_symbols": \[\]' "$j" || { echo "$j: the firmware links a panic path:"; grep -A8 '"panic_symbols"' "$j"; exit 1; }
done
echo "none on $(boards | tr '\n' ' ')nor in the driven camera on the M3 and the M0"

echo "== the M0 within 3x the M3 on the standard scene (instructions/pixel under QEMU -icount, the default build)"
m0=$(awk -F': ' '/^  "instructions_per_pixel"/ { gsub(",", "", $2); print $2 }' out/hil/microbit/hil.json)
m3=$(awk -F': ' '/^  "instructions_per_pixel"/ { gsub(",", "", $2); print $2 }' out/hil/lm3s6965evb/hil.json)
awk -v m0="$m0" -v m3="$m3" 'BEGIN { r = (m3 > 0) ? m0 / m3 : 0; printf "M0 %.0f / M3 %.0f = %.2f\n", m0, m3, r; exit !(m3 > 0 && r <= 3) }' ||
  { echo "the M0 is over 3x the M3 on the standard scene (or not measured)"; exit 1; }

echo "== the compact loops (the driven camera's: one copy serves one and three channels) bit-exact on every shipped scene, M3"
# The default firmware with the core's compact feature: the same frames as
# the host's, through the loops the driven camera runs (every scene here;
# the drives above send it the standard scene alone).
(cd firmware && CARGO_PROFILE_RELEASE_OPT_LEVEL=s cargo build -q --release --no-default-features \
  --features status,mix32,sensor,shadows,hilcam/compact --target thumbv7m-none-eabi)
"$HILCAM_HOST_SIM" hil --board lm3s6965evb --elf firmware/target/thumbv7m-none-eabi/release/hilcam-firmware \
  --out target/hil/lm3s6965evb-compact | tail -3

echo "== firmware built for size (opt-level z, no status): the M3 image within 64 KiB of flash, still bit-exact"
# Without the fast arithmetic (the core's mix32 feature): the wide one, which
# the host renders as the variant i32f32-poly. Without the sensor stages too
# (the core's sensor feature), so it embeds the scenes without [noise] that
# are not defocused (shallow-dof's content lies outside its depth of field),
# each asking for one sample a pixel (a scene without [sampling] gets the
# sensor's area integration, a stage this build leaves out).
mkdir -p target/scenes-point
rm -f target/scenes-point/*.toml
# (Nor cast shadows, the core's shadows feature: the copies turn them off;
# the shadows scene is not one the boards hold: boards.toml skip_scenes.)
for s in $(grep -L -E '^\[(sampling|noise)\]' scenes/*.toml | grep -v -e shallow-dof -e /shadows.toml); do
  { sed 's/^\[environment\]$/[environment]\nshadows = false/' "$s"; printf '\n[sampling]\nedge_error = 0.5\n'; } \
    > "target/scenes-point/$(basename "$s")"
done
small_scenes=$(ls target/scenes-point/*.toml)
(cd firmware && HILCAM_SCENES="$(for s in $small_scenes; do echo "$PWD/../$s"; done)" HILCAM_VARIANTS=i32f32-poly \
  CARGO_PROFILE_RELEASE_OPT_LEVEL=z \
  cargo build -q --release --no-default-features --target thumbv7m-none-eabi)
# shellcheck disable=SC2086
"$HILCAM_HOST_SIM" hil --board lm3s6965evb --elf firmware/target/thumbv7m-none-eabi/release/hilcam-firmware \
  --scene $small_scenes --variant i32f32-poly --out target/hil/lm3s6965evb-small | tail -3
awk -F': ' '/"flash_bytes"/ { gsub(",", "", $2); if ($2 + 0 > 65536) { print "flash " $2 " B > 64 KiB"; bad = 1 } } END { exit bad }' \
  target/hil/lm3s6965evb-small/hil.json

echo "== fuzz smoke run: every cargo-fuzz target for 15 s (nightly + cargo-fuzz, installed if missing; built above)"
wait "$fuzz_build" || { cat target/fuzz-build.log; echo "the fuzz targets' build failed"; exit 1; }
./scripts/fuzz.sh "" 15 | tee target/fuzz-smoke.log
if grep -qE "ERROR|panicked|SUMMARY" target/fuzz-smoke.log; then echo "fuzzing found a failure"; exit 1; fi
[ "$(grep -c '^Done' target/fuzz-smoke.log)" -ge 5 ] || { echo "a fuzz target did not run"; exit 1; }

echo "== largest errors measured by the property tests (core vs f64 reference)"
cat target/tmp/accuracy/*.txt
