#!/usr/bin/env bash
# Runs a cargo-fuzz target for a given time: ./scripts/fuzz.sh [TARGET] [SECONDS]
# (default: every target, 60 s each); ./scripts/fuzz.sh --build builds every
# target and runs none. Needs the nightly toolchain and cargo-fuzz; installs
# both if missing.
set -euo pipefail
cd "$(dirname "$0")/../fuzz"
command -v cargo-fuzz >/dev/null || cargo install cargo-fuzz --locked
rustup toolchain list | grep -q nightly || rustup toolchain install nightly --profile minimal
# Every target in one cargo run (in parallel, the dependencies once), with
# the flags `fuzz run` builds with: each run then starts at once.
build_all() { cargo +nightly fuzz build; }
if [ "${1:-}" = --build ]; then
  build_all
  exit
fi
targets=${1:-$(cargo +nightly fuzz list)}
secs=${2:-60}
# Without a target named, every target built first. (A failed build shows
# as its runs' failure, which the test command counts: no `Done` line.)
[ -n "${1:-}" ] || build_all 2>&1 | grep -vE "^ +(Compiling|Finished|Building)" || true
# The targets run side by side, one a core (each libFuzzer process is one
# thread): the same time each, in a fraction of the wall time. Each one's
# lines are printed together, in the targets' order.
jobs=$(nproc 2>/dev/null || echo 1)
logs=$(mktemp -d)
trap 'rm -rf "$logs"' EXIT
n=0
for t in $targets; do
  (cargo +nightly fuzz run "$t" -- -max_total_time="$secs" 2>&1 | grep -E "^Done|ERROR|panicked|SUMMARY" || true) > "$logs/$t" &
  n=$((n + 1))
  [ $((n % jobs)) -ne 0 ] || wait
done
wait
for t in $targets; do
  echo "== fuzz $t for ${secs}s"
  cat "$logs/$t"
done
