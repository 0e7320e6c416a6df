#!/usr/bin/env bash
# Trains the age channel into the shipped model (docs/MODEL.md "The age
# channel"): the dataset of configs/dataset/age.json (the reef recipe with
# each pair's erosion maturity drawn in [0.1, 20]) built with today's
# generator, then one stage of configs/train/age.json (GAN + 500·L1, lr 5e-5
# decaying to 0 over 0.8 epoch, maturity_channel on) started from the shipped
# G widened by a fourth input plane whose weights start at zero (D fresh),
# then the float16 pack and the held-out and painted measurements. ~30 min
# on 2 cores with avx512_bf16; Ctrl-C and run again to resume. Work folders
# go to $WORK (default ../reefgen-age), outside the repository.
#   bash scripts/train-age.sh
#   PRECISION=fp32 bash scripts/train-age.sh   # CPUs without avx512_bf16/AMX (docs/TRAINING.md)
set -euo pipefail
cd "$(dirname "$0")/.."
[ -x build/cli/reefgen-torch ] || bash scripts/build.sh >&2
BIN=build/cli/reefgen
WORK=${WORK:-../reefgen-age}
mkdir -p "$WORK"
$BIN dataset build --config configs/dataset/age.json --seed 11 --out "$WORK/data" >/dev/null
P=${PRECISION:-bf16}
if [ -f "$WORK/age/checkpoint.pt" ]; then
  $BIN train --data "$WORK/data" --out "$WORK/age" --resume >/dev/null
else
  $BIN train --config configs/train/age.json --data "$WORK/data" --out "$WORK/age" --precision "$P" \
    --init models/reef-256.pt >/dev/null
fi
$BIN model pack "$WORK/age/generator.pt" -o "$WORK/reef-256.pt" --storage float16 >/dev/null
$BIN -q eval -m "$WORK/reef-256.pt" --data "$WORK/data" --split test --out "$WORK/eval" > /dev/null
$BIN -q eval-sketches tests/data/painted -m "$WORK/reef-256.pt" --out "$WORK/eval-painted" > /dev/null
echo "model: $WORK/reef-256.pt (copy it to models/ to ship it)"
echo "held-out test: $WORK/eval/eval.md; painted sketches: $WORK/eval-painted/sketches.json, grid.png"
