#!/usr/bin/env bash
# Fine-tunes the shipped model (models/reef-256.pt) on the generator's
# current targets (docs/MODEL.md "Fine-tuned on the trunk basins"): the
# dataset of configs/dataset/shipped.json rebuilt with today's generator,
# then one stage of configs/train/shipped-land.json (GAN + 500·L1, lr 5e-5
# decaying to 0 over 0.8 epoch) started from the shipped G (D fresh), then
# the float16 pack and the measurements of docs/MODEL.md "Fine-tuned on the
# trunk basins". ~30 min on 2 cores
# with avx512_bf16; Ctrl-C and run again to resume. Work folders go to
# $WORK (default ../reefgen-finetune), outside the repository.
# DATA_CONFIG, TRAIN_CONFIG and STAGE choose another recipe (scripts/train-age.sh).
#   bash scripts/finetune-shipped.sh
#   PRECISION=fp32 bash scripts/finetune-shipped.sh   # CPUs without avx512_bf16/AMX (docs/TRAINING.md)
set -euo pipefail
cd "$(dirname "$0")/.."
[ -x build/cli/reefgen-torch ] || bash scripts/build.sh >&2
BIN=build/cli/reefgen
WORK=${WORK:-../reefgen-finetune}
DATA_CONFIG=${DATA_CONFIG:-configs/dataset/shipped.json}
TRAIN_CONFIG=${TRAIN_CONFIG:-configs/train/shipped-land.json}
STAGE=${STAGE:-land}
mkdir -p "$WORK"
$BIN dataset build --config "$DATA_CONFIG" --seed 11 --out "$WORK/data" >/dev/null
P=${PRECISION:-bf16}
if [ -f "$WORK/$STAGE/checkpoint.pt" ]; then
  $BIN train --data "$WORK/data" --out "$WORK/$STAGE" --resume >/dev/null
else
  $BIN train --config "$TRAIN_CONFIG" --data "$WORK/data" --out "$WORK/$STAGE" --precision "$P" \
    --init models/reef-256.pt >/dev/null
fi
$BIN model pack "$WORK/$STAGE/generator.pt" -o "$WORK/reef-256.pt" --storage float16 >/dev/null
$BIN -q eval -m "$WORK/reef-256.pt" --data "$WORK/data" --split test --out "$WORK/eval" > /dev/null
$BIN -q eval-sketches tests/data/painted -m "$WORK/reef-256.pt" --out "$WORK/eval-painted" > /dev/null
echo "model: $WORK/reef-256.pt (copy it to models/ to ship it)"
echo "held-out test: $WORK/eval/eval.md; painted sketches: $WORK/eval-painted/sketches.json, grid.png"
