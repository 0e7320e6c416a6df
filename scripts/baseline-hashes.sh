#!/usr/bin/env bash
# SHA-256 of a fixed set of outputs (generate, erode, infer, world, the engine
# bundles, a dataset) — run before and after a change that must not change
# behaviour, and compare the two lists (`diff`). Sidecars (*.json) are left
# out: they record the version and the command line.
#
#   bash scripts/baseline-hashes.sh build/cli/reefgen /tmp/before > before.sha
#   ... change ...
#   bash scripts/baseline-hashes.sh build/cli/reefgen /tmp/after > after.sha
#   diff before.sha after.sha && echo same
set -euo pipefail
BIN=${1:?usage: baseline-hashes.sh REEFGEN OUT_DIR}
OUT=${2:?usage: baseline-hashes.sh REEFGEN OUT_DIR}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
PAINTED=$ROOT/tests/data/painted
rm -rf "$OUT" && mkdir -p "$OUT"
run() { "$BIN" -q "$@" >/dev/null; }

run generate --preset barrier-reef --size 513 -o "$OUT/gen/reef" --for unity,unreal,gis,godot,blender --layers
run generate --preset young-volcano --size 257 --age-myr 2 -o "$OUT/gen/aged"
run generate --random 1 --seed 3 --size 257 --out "$OUT/gen/random"
run erode "$(ls "$OUT"/gen/random/*.height.exr | head -1)" -o "$OUT/erode/random" --for gis
if [ -x "$(dirname "$BIN")/reefgen-torch" ]; then
  run infer "$PAINTED/01-young-volcano.png" -o "$OUT/infer/yv256"
  run infer "$PAINTED/01-young-volcano.png" --size 1025 --seed 2 -o "$OUT/infer/yv1025" --for unity,gis
  run infer "$PAINTED/01-young-volcano.png" --size 513 --variations 2 -o "$OUT/infer/var"
  run world "$PAINTED/03-two-islands.png" --size 2049 -o "$OUT/world/two" --for unreal
fi
cat > "$OUT/ds.json" <<'EOF'
{"count": 6, "size_px": 64, "levels": 3, "val_fraction": 0.2, "test_fraction": 0.2, "age_min_myr": 0.5, "age_max_myr": 5}
EOF
run dataset build --config "$OUT/ds.json" --seed 4 --out "$OUT/dataset" --threads 2

cd "$OUT" && find . -type f ! -name '*.json' ! -name 'ds.json' | LC_ALL=C sort | xargs sha256sum
