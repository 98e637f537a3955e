#!/usr/bin/env bash
# Runs every check and test of hilcam. Works on a fresh machine with only
# rustup: it installs the thumb targets and components it needs.
set -euo pipefail
cd "$(dirname "$0")/.."

echo "== toolchain (targets and components from rust-toolchain.toml)"
rustup component add clippy rustfmt >/dev/null
rustup target add thumbv6m-none-eabi thumbv7m-none-eabi thumbv7em-none-eabihf >/dev/null
rustc --version

echo "== format"
cargo fmt --all -- --check

echo "== clippy: workspace, warnings are errors"
cargo clippy --workspace --all-targets -q -- -D warnings

echo "== clippy: core on thumbv7m with the panic-free lints"
cargo clippy --lib --target thumbv7m-none-eabi -q -- -D warnings \
  -D clippy::unwrap_used -D clippy::expect_used -D clippy::panic -D clippy::indexing_slicing

echo "== core builds for the Cortex-M targets"
for target in thumbv6m-none-eabi thumbv7m-none-eabi thumbv7em-none-eabihf; do
  cargo build -q --lib --release --target "$target"
  echo "   $target: ok"
done
cargo build -q --lib --release --target thumbv7em-none-eabihf --features defmt
echo "   thumbv7em-none-eabihf --features defmt: ok"

echo "== tests"
rm -rf target/tmp/accuracy
cargo test --workspace

echo "== largest errors measured by the property tests (core vs f64 reference)"
cat target/tmp/accuracy/*.txt
