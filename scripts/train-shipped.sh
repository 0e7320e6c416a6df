#!/usr/bin/env bash
# Rebuilds the shipped model (models/reef-256.pt) from scratch: the dataset of
# configs/dataset/shipped.json, the four training stages of docs/MODEL.md §4
# (configs/train/shipped.json, then configs/train/shipped-tune.json,
# shipped-tune2.json and shipped-tune3.json, each started with --init from the
# one before; ~4 h 15 min on 2 cores; Ctrl-C and run again to
# resume), then the float16 pack and the measurements of docs/MODEL.md. Work
# folders go to $WORK (default ../reefgen-work), outside the repository.
#   bash scripts/train-shipped.sh            # all steps, resuming what is done
#   PRECISION=fp32 bash scripts/train-shipped.sh   # fp32 convolutions: for CPUs without avx512_bf16/AMX,
#                                                  # where bf16 is slow (docs/TRAINING.md); not the shipped recipe
set -euo pipefail
cd "$(dirname "$0")/.."
[ -x build/cli/reefgen-torch ] || bash scripts/build.sh >&2
BIN=build/cli/reefgen
WORK=${WORK:-../reefgen-work}
mkdir -p "$WORK"
$BIN dataset build --config configs/dataset/shipped.json --seed 11 --out "$WORK/data" >/dev/null
P=${PRECISION:-bf16}
# Stage 1 (GAN + 100·L1). A finished run is recognised by its generator.pt
# at the last step; a resume of a finished run returns at once.
if [ -f "$WORK/run/checkpoint.pt" ]; then
  $BIN train --data "$WORK/data" --out "$WORK/run" --resume >/dev/null
else
  $BIN train --config configs/train/shipped.json --data "$WORK/data" --out "$WORK/run" --precision "$P" >/dev/null
fi
# Stage 2 (GAN + 250·L1) from stage 1's weights.
if [ -f "$WORK/tune/checkpoint.pt" ]; then
  $BIN train --data "$WORK/data" --out "$WORK/tune" --resume >/dev/null
else
  $BIN train --config configs/train/shipped-tune.json --data "$WORK/data" --out "$WORK/tune" --precision "$P" \
    --init "$WORK/run/checkpoint.pt" >/dev/null
fi
# Stage 3 (GAN + 500·L1, lr 5e-5 decaying to 0) from stage 2's weights.
if [ -f "$WORK/tune2/checkpoint.pt" ]; then
  $BIN train --data "$WORK/data" --out "$WORK/tune2" --resume >/dev/null
else
  $BIN train --config configs/train/shipped-tune2.json --data "$WORK/data" --out "$WORK/tune2" --precision "$P" \
    --init "$WORK/tune/checkpoint.pt" >/dev/null
fi
# Stage 4 (GAN + 2000·L1, lr 5e-5 decaying to 0 over 0.6 epoch) from stage 3's.
if [ -f "$WORK/tune3/checkpoint.pt" ]; then
  $BIN train --data "$WORK/data" --out "$WORK/tune3" --resume >/dev/null
else
  $BIN train --config configs/train/shipped-tune3.json --data "$WORK/data" --out "$WORK/tune3" --precision "$P" \
    --init "$WORK/tune2/checkpoint.pt" >/dev/null
fi
$BIN model pack "$WORK/tune3/generator.pt" -o "$WORK/reef-256.pt" --storage float16 >/dev/null
$BIN -q eval -m "$WORK/reef-256.pt" --data "$WORK/data" --split test --out "$WORK/eval" > /dev/null
$BIN -q eval-sketches tests/data/painted -m "$WORK/reef-256.pt" --out "$WORK/eval-painted" > /dev/null
echo "model: $WORK/reef-256.pt (copy it to models/ to ship it)"
echo "held-out test: $WORK/eval/eval.md; painted sketches: $WORK/eval-painted/sketches.json, grid.png"
