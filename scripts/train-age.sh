#!/usr/bin/env bash
# Trains the age channel into the shipped model (docs/MODEL.md "The age
# channel"): the dataset of configs/dataset/age.json (the reef recipe with
# each pair's erosion maturity drawn in [0.1, 20]) built with today's
# generator, then one stage of configs/train/age.json (GAN + 500·L1, lr 5e-5
# decaying to 0 over 0.8 epoch, maturity_channel on) started from the shipped
# G widened by a fourth input plane whose weights start at zero (D fresh),
# then the float16 pack and the held-out and painted measurements — the
# steps of scripts/finetune-shipped.sh with this recipe. ~40 min on 2 cores
# with avx512_bf16; Ctrl-C and run again to resume. Work folders go to
# $WORK (default ../reefgen-age), outside the repository.
#   bash scripts/train-age.sh
#   PRECISION=fp32 bash scripts/train-age.sh   # CPUs without avx512_bf16/AMX (docs/TRAINING.md)
set -euo pipefail
cd "$(dirname "$0")/.."
WORK=${WORK:-../reefgen-age} DATA_CONFIG=configs/dataset/age.json TRAIN_CONFIG=configs/train/age.json STAGE=age \
  exec bash scripts/finetune-shipped.sh
