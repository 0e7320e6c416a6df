#!/usr/bin/env bash
# Rebuilds the shipped model of the reef (models/reef-256.pt, docs/REEF.md,
# docs/MODEL.md, models/README.md). First the reef model of 2026-11-27: the
# dataset of configs/dataset/shipped.json (seed 11) on the reef generator,
# configs/train/reef-finetune.json started with --init from the model shipped
# before the reef (G only, D fresh), then configs/train/reef-shore.json (L1
# weighted ×11 at sea level) with --init from that, packed as float16. Then
# the ring stages on configs/dataset/reef.json (seed 11: the same islands,
# the sea floor redrawn): configs/train/reef-rise.json with --init from that
# pack (G only, D fresh; the ring loss and the logit bound), then
# configs/train/reef-rise2.json and configs/train/reef-rise3.json, each with
# --init from the checkpoint before it (G and D); the float16 pack and the
# measurements. Work folders go to $WORK (default
# ../reefgen-work-reef), outside the repository; Ctrl-C and run it again to
# resume.
#   bash scripts/train-reef.sh [BASE_MODEL]   # BASE_MODEL: the generator to start from
#                                             # (default: the pre-reef model from git history, commit 6938da5)
set -euo pipefail
cd "$(dirname "$0")/.."
[ -x build/cli/reefgen-torch ] || bash scripts/build.sh >&2
BIN=build/cli/reefgen
WORK=${WORK:-../reefgen-work-reef}
mkdir -p "$WORK"
BASE=${1:-$WORK/base-256.pt}
if [ ! -f "$BASE" ]; then
  # The model shipped before the reef, from the repository's history.
  git show 6938da5:models/reef-256.pt > "$BASE.tmp" && mv "$BASE.tmp" "$BASE"
fi
$BIN dataset build --config configs/dataset/shipped.json --seed 11 --out "$WORK/data" >/dev/null
$BIN dataset build --config configs/dataset/reef.json --seed 11 --out "$WORK/data-reef" >/dev/null
# One stage: resumed from its checkpoint if one is there (a finished run
# only exports its generator again), else started from INIT.
stage() {  # stage CONFIG DATA RUN INIT
  if [ -f "$3/checkpoint.pt" ]; then
    $BIN train --data "$2" --out "$3" --resume >/dev/null
  else
    $BIN train --config "$1" --data "$2" --out "$3" --init "$4" >/dev/null
  fi
}
stage configs/train/reef-finetune.json "$WORK/data" "$WORK/run" "$BASE"
stage configs/train/reef-shore.json "$WORK/data" "$WORK/shore" "$WORK/run/generator.pt"
$BIN model pack "$WORK/shore/generator.pt" -o "$WORK/shore-256.pt" --storage float16 >/dev/null
stage configs/train/reef-rise.json "$WORK/data-reef" "$WORK/rise" "$WORK/shore-256.pt"
stage configs/train/reef-rise2.json "$WORK/data-reef" "$WORK/rise2" "$WORK/rise/checkpoint.pt"
stage configs/train/reef-rise3.json "$WORK/data-reef" "$WORK/rise3" "$WORK/rise2/checkpoint.pt"
$BIN model pack "$WORK/rise3/generator.pt" -o "$WORK/reef-256.pt" --storage float16 >/dev/null
$BIN -q eval -m "$WORK/reef-256.pt" --data "$WORK/data-reef" --split test --out "$WORK/eval" >/dev/null
$BIN -q eval-sketches tests/data/painted -m "$WORK/reef-256.pt" --out "$WORK/eval-painted" >/dev/null
PY=/usr/bin/python3; [ -x "$PY" ] || PY=python3
"$PY" scripts/reef-bars.py -m "$WORK/reef-256.pt" --out "$WORK/reef-bars" > "$WORK/reef-bars.json"
echo "model: $WORK/reef-256.pt (copy it to models/ to ship it)"
echo "held-out test: $WORK/eval/eval.md; painted sketches: $WORK/eval-painted/sketches.json; reef bars: $WORK/reef-bars.json"
