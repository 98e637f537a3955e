#!/usr/bin/env bash
# Re-renders the shipped scenes (./scripts/emulate.sh) and copies the
# pictures the README shows into docs/images/.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/emulate.sh >/dev/null
mkdir -p docs/images
for dir in out/*/; do
  name=$(basename "$dir")
  for kind in frame reference diff; do
    cp "$dir/$kind.png" "docs/images/$name-$kind.png"
  done
done
ls docs/images
