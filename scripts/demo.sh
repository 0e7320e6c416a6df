#!/usr/bin/env bash
# The main job on built-in defaults: sets up, builds, turns a painted sketch
# into an island with the shipped model (models/, docs/MODEL.md), generates
# every preset and a few random islands, then runs the learning pipeline end
# to end in miniature (a small dataset, a short training, inference) into ./out.
set -euo pipefail
cd "$(dirname "$0")/.."
# The torch-free half first (a third of the build): a curve island shows
# before LibTorch's files compile. scripts/test.sh builds the tests.
bash scripts/build.sh reefgen
BIN=build/cli/reefgen
mkdir -p out/first
$BIN -q generate --preset young-volcano -o out/first/island --preview >/dev/null
echo "first island after ${SECONDS} s: out/first/island.preview.png (heights: island.height.exr); building the network commands..." >&2
bash scripts/build.sh programs
# The main job: a painted sketch -> a terrain, no training needed.
mkdir -p out/shipped
$BIN -q infer docs/examples/painted-sketch.png -o out/shipped/island --preview --png16 --r16 --mesh glb >/dev/null
$BIN -q eval-sketches tests/data/painted --out out/shipped/painted >/dev/null
mkdir -p out/presets
for p in $($BIN presets | awk '{print $1}'); do
  $BIN generate --preset "$p" -o "out/presets/$p" --preview >/dev/null
done
$BIN -q generate --random 4 --seed 1 --levels 3 --preview --out out/random >/dev/null
# The other island systems: mapgen4- and Wilbur-style terrains, a floating island.
mkdir -p out/islands
$BIN -q terrain mapgen4 --seed 2 -o out/islands/mapgen4 --preview >/dev/null
$BIN -q terrain wilbur --seed 5 -o out/islands/wilbur --preview >/dev/null
$BIN -q floating --painting docs/examples/floating-painting.png -o out/islands/floating.glb \
  -o out/islands/floating.obj --preview out/islands/floating.png >/dev/null

# Pipeline in miniature (~1 min): 128 pairs, 150 steps of a small pix2pix.
rm -rf out/pipeline
$BIN -q dataset build --count 128 --seed 1 --out out/pipeline/data >/dev/null
$BIN -q train --data out/pipeline/data --out out/pipeline/run --ngf 16 --ndf 16 --max-steps 150 >/dev/null
$BIN sketch random --seed 3 -o out/pipeline/sketch.png >/dev/null
$BIN -q infer out/pipeline/sketch.png -m out/pipeline/run/generator.pt -o out/pipeline/island \
  --preview --png16 --r16 --mesh glb >/dev/null

echo
echo "Written to $(pwd)/out:"
echo "  out/first/island.preview.png   the first island: the curve generator's young volcano"
echo "  out/shipped/island.preview.png docs/examples/painted-sketch.png turned into an island by the shipped model"
echo "                                 (island.height.exr metres, .height.png 16-bit, .r16, .glb); paint your own:"
echo "                                 $BIN infer my-sketch.png -o out/mine --preview   (colours: docs/INFERENCE.md)"
echo "  out/shipped/painted/grid.png   the 14 test sketches of tests/data/painted and their islands"
echo "  out/presets/NAME.preview.png   the curve generator's presets ($($BIN presets | awk '{print $1}' | paste -sd' '))"
echo "  out/presets/NAME.height.exr    heights in metres, channel Y, sea level 0"
echo "  out/presets/NAME.label.png     HSV label map; NAME.json the sidecar"
echo "  out/random/                    4 random islands at 3 subsidence levels each"
echo "  out/islands/                   mapgen4- and Wilbur-style terrains; floating.{glb,obj,png} from docs/examples/floating-painting.png"
echo "  out/pipeline/                  dataset -> 150-step training (run/log.csv, run/val/*.png)"
echo "                                 -> sketch.png -> island.{height.exr,preview.png,glb,r16} (an untrained model: a demo of the plumbing)"
