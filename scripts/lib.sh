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
  rustup target add thumbv6m-none-eabi thumbv7m-none-eabi thumbv7em-none-eabihf >/dev/null 2>&1 ||
    rustup target add thumbv6m-none-eabi thumbv7m-none-eabi thumbv7em-none-eabihf
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

# Builds the firmware for the three Cortex-M targets: the M3 and M4F at the
# release profile's opt-level "s", the M0 (QEMU's microbit) at 3, whose
# 64-bit products opt-level "s" leaves slower (host-sim's Board::opt_level).
build_firmware() {
  (cd firmware &&
    cargo build -q --release --features board-lm3s6965 --target thumbv7m-none-eabi &&
    cargo build -q --release --features board-mps2-an386 --target thumbv7em-none-eabihf &&
    CARGO_PROFILE_RELEASE_OPT_LEVEL=3 cargo build -q --release --features board-microbit --target thumbv6m-none-eabi)
}
