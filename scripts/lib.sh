# Shared by the scripts.

# The scripts build from scratch on a fresh machine, where incremental
# compilation's bookkeeping only costs time.
export CARGO_INCREMENTAL=0

# Installs what every entry point builds with: the thumb targets and the
# components. rust-toolchain.toml alone does not add targets to an installed
# stable toolchain on a fresh machine (cargo then fails with "can't find crate
# for core"), so both README commands call this first.
ensure_toolchain() {
  rustup component add clippy rustfmt >/dev/null 2>&1 || rustup component add clippy rustfmt
  # The targets of every board in firmware/boards.toml.
  local targets
  targets=$(sed -n 's/^target = "\(.*\)"/\1/p' firmware/boards.toml | sort -u)
  # shellcheck disable=SC2086
  rustup target add $targets >/dev/null 2>&1 || rustup target add $targets
}

# A board's field in firmware/boards.toml (board_field BOARD FIELD).
board_field() {
  awk -v b="$1" -v f="$2" '
    /^\[\[board\]\]/ { inb = 0 }
    /^name = / { inb = ($3 == "\"" b "\"") }
    inb && $1 == f { v = $3; gsub("\"", "", v); print v; exit }' firmware/boards.toml
}

# Installs qemu-system-arm when it is missing and this is root on a
# Debian-like machine. Returns non-zero if QEMU is unavailable.
ensure_qemu() {
  command -v qemu-system-arm >/dev/null 2>&1 && return 0
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
    echo "   installing qemu-system-arm (apt-get)"
    apt-get update -qq >/dev/null 2>&1 || true
    DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends qemu-system-arm >/dev/null 2>&1 || return 1
    command -v qemu-system-arm >/dev/null 2>&1 && return 0
  fi
  return 1
}

# Every board's name, in the table's order.
boards() {
  sed -n 's/^name = "\(.*\)"/\1/p' firmware/boards.toml
}

# Builds the default firmware for BOARD (firmware/boards.toml) at its
# opt-level, as host-sim does: firmware/target/<target>/release/hilcam-firmware.
build_firmware() {
  local board=$1 target opt
  target=$(board_field "$board" target)
  opt=$(board_field "$board" opt_level)
  # The environment host-sim's build gives it (hil_cmd, qemu.rs), so that
  # a `host-sim hil` after this finds it built.
  (cd firmware && HILCAM_BOARD="$board" CARGO_PROFILE_RELEASE_OPT_LEVEL="${opt:-s}" \
    HILCAM_SCENES= HILCAM_VARIANTS= HILCAM_MAX_MATERIALS=4 HILCAM_MAX_PRIMITIVES=4 HILCAM_MAX_LIGHTS=1 \
    cargo build -q --release --target "$target")
}

# A Python virtual environment in target/venv with the hilcam package
# (python/, built by maturin from this workspace) and what the OpenCV checks
# and the package's tests need — never the system interpreter's packages.
ensure_venv() {
  if [ ! -x target/venv/bin/python ]; then
    mkdir -p target
    python3 -m venv target/venv
  fi
  target/venv/bin/python -c "import cv2, numpy, pytest, yaml, maturin" >/dev/null 2>&1 ||
    target/venv/bin/python -m pip install -q numpy opencv-python-headless pytest pyyaml "maturin>=1.7,<2"
  # The package from this tree (its cargo build kept in target/python, so
  # that an unchanged tree rebuilds in seconds).
  PATH="$PWD/target/venv/bin:$PATH" CARGO_TARGET_DIR="$PWD/target/python" target/venv/bin/python -m pip install -q --no-build-isolation --force-reinstall --no-deps ./python
}
