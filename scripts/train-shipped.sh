#!/usr/bin/env bash
# Rebuilds the shipped model (models/reef-256.pt) from scratch: the dataset of
# configs/dataset/shipped.json, the training of configs/train/shipped.json
# (~90 min on 2 cores; Ctrl-C and run again to resume), then the float16 pack
# and the measurements of docs/MODEL.md. Work folders go to $WORK (default
# ../reefgen-work), outside the repository.
#   bash scripts/train-shipped.sh            # all steps, resuming what is done
#   PRECISION=bf16 bash scripts/train-shipped.sh   # bf16 convolutions: ~1.4x faster where the CPU has
#                                                  # avx512_bf16/AMX (docs/TRAINING.md); not the shipped file's recipe
set -euo pipefail
cd "$(dirname "$0")/.."
[ -x build/cli/reefgen ] || bash scripts/build.sh >&2
BIN=build/cli/reefgen
WORK=${WORK:-../reefgen-work}
mkdir -p "$WORK"
$BIN dataset build --config configs/dataset/shipped.json --seed 11 --out "$WORK/data" >/dev/null
if [ -f "$WORK/run/checkpoint.pt" ]; then
  $BIN train --data "$WORK/data" --out "$WORK/run" --resume >/dev/null
else
  $BIN train --config configs/train/shipped.json --data "$WORK/data" --out "$WORK/run" --precision "${PRECISION:-fp32}" >/dev/null
fi
$BIN model pack "$WORK/run/generator.pt" -o "$WORK/reef-256.pt" --storage float16 >/dev/null
$BIN -q eval -m "$WORK/reef-256.pt" --data "$WORK/data" --split test --max-pairs 300 --out "$WORK/eval" > /dev/null
$BIN -q eval-sketches tests/data/painted -m "$WORK/reef-256.pt" --out "$WORK/eval-painted" > /dev/null
echo "model: $WORK/reef-256.pt (copy it to models/ to ship it)"
echo "held-out test: $WORK/eval/eval.md; painted sketches: $WORK/eval-painted/sketches.json, grid.png"
