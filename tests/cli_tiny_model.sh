#!/usr/bin/env bash
# ctest's tiny_model fixture (tests/CMakeLists.txt): the 12-pair dataset and
# the tiny model trained on it, which cli_infer_test.sh and
# cli_infer_models_test.sh read (one training for both). Also run by either
# script on its own when REEFGEN_TINY_MODEL is not set.
#   bash tests/cli_tiny_model.sh REEFGEN DIR   → DIR/ds.json DIR/d1/ DIR/tr.json DIR/t1/generator.pt
set -euo pipefail
BIN="$1" DIR="$2"
source "$(dirname "$0")/cli_tiny_args.sh"
rm -rf "$DIR.partial" && mkdir -p "$DIR.partial"
tiny_configs "$DIR.partial"
"$BIN" -q dataset build --config "$DIR.partial/ds.json" --seed 4 --out "$DIR.partial/d1" --threads 1 >/dev/null
# shellcheck disable=SC2086  # TINY_TRAIN is a list of flags
"$BIN" -q train --config "$DIR.partial/tr.json" --data "$DIR.partial/d1" $TINY_TRAIN --out "$DIR.partial/t1" >/dev/null
# Complete or absent: a fixture stopped half-way is never read.
rm -rf "$DIR" && mv "$DIR.partial" "$DIR"
