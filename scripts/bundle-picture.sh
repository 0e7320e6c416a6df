#!/usr/bin/env bash
# Rebuilds docs/finished-island.png: the young-volcano preset at 2049²
# exported with `--for blender` and rendered by Debian's Blender (Cycles on
# the CPU, headless) from the bundle's GLB exactly as a user imports it:
# mesh 1025², base colour = the material layers, normal texture at 2049².
# Needs blender (apt-get install blender). About two minutes on two cores.
set -euo pipefail
cd "$(dirname "$0")/.."
R=build/cli/reefgen
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
$R -q generate --preset young-volcano --size 2049 --seed 1 -o "$W/isle" --for blender >/dev/null
blender -b -noaudio --factory-startup --python scripts/render_bundle.py -- "$W/isle.blender" isle "$W/render.png" 1400 800 24 \
  >"$W/log" 2>&1 || { tail -20 "$W/log"; exit 1; }
cp "$W/render.png" docs/finished-island.png
echo "docs/finished-island.png"
