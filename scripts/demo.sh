#!/usr/bin/env bash
# The main job on built-in defaults: sets up, builds, then generates every
# preset and a few random islands, with previews, into ./out.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/build.sh
BIN=build/cli/reefgen
mkdir -p out/presets
for p in $($BIN presets | awk '{print $1}'); do
  $BIN generate --preset "$p" -o "out/presets/$p" --preview >/dev/null
done
$BIN -q generate --random 4 --seed 1 --levels 3 --preview --out out/random >/dev/null
echo
echo "Islands written to $(pwd)/out:"
echo "  out/presets/NAME.preview.png   look at these first (presets: $($BIN presets | awk '{print $1}' | paste -sd' '))"
echo "  out/presets/NAME.height.exr    heights in metres, channel Y, sea level 0"
echo "  out/presets/NAME.label.png     HSV label map; NAME.json the sidecar"
echo "  out/random/                    4 random islands at 3 subsidence levels each"
