#!/usr/bin/env bash
# Rebuilds docs/variations.png (docs/INFERENCE.md "Variations"): top row
# tests/data/painted/01-young-volcano.png and its islands through
# `infer --size 1025` with seeds 1, 2 and 3; bottom row the same painting
# with its west half in pastel (saturation 0.3, "Per-region style"), its
# answer with seed 1 (smooth shield | rugged), the full-colour answer with
# seed 1, and the model's own 256² answer re-rolled with seed 1. Each tile
# is the island's 3 km, hill-shaded. Prints the realism statistics.
# Needs python3-numpy and python3-opencv.
set -euo pipefail
cd "$(dirname "$0")/.."
R=build/cli/reefgen
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
S=tests/data/painted/01-young-volcano.png
python3 - "$S" "$W/pastel.png" <<'EOF'
import sys, cv2, numpy as np
im = cv2.imread(sys.argv[1]).astype(np.float32)
top = im.max(axis=2, keepdims=True)
pastel = top - 0.3 * (top - im)  # the same brightness, 30 % of the chroma
half = im.shape[1] // 2
im[:, :half] = pastel[:, :half]
cv2.imwrite(sys.argv[2], np.round(im).astype(np.uint8))
EOF
for s in 1 2 3; do $R -q infer "$S" --size 1025 --seed $s -o "$W/seed$s" >/dev/null; done
$R -q infer "$W/pastel.png" --size 1025 --seed 1 -o "$W/pastel" >/dev/null
$R -q infer "$S" --seed 1 -o "$W/model" >/dev/null
for f in seed1 seed2 seed3 pastel model; do $R realism "$W/$f.height.exr"; done
python3 - "$W" "$S" <<'EOF'
import os, sys
os.environ["OPENCV_IO_ENABLE_OPENEXR"] = "1"
import cv2, numpy as np
w, sketch = sys.argv[1], sys.argv[2]
T = 340  # tile side, px

def height(name):
    h = cv2.imread(f"{w}/{name}.height.exr", cv2.IMREAD_UNCHANGED)
    return (h[:, :, 0] if h.ndim == 3 else h).astype(np.float64)

# The island's 3 km (half the 6 km canvas) round the land of seed 1, as shares of the canvas.
land = np.argwhere(height("seed1") > 0)
cy, cx = (land.min(0) + land.max(0)) / 2 / 1025
x0, y0 = np.clip(cx - 0.25, 0, 0.5), np.clip(cy - 0.25, 0, 0.5)

def crop(img):
    n = img.shape[0]
    a, b = int(y0 * n), int(x0 * n)
    return cv2.resize(img[a:a + n // 2, b:b + n // 2], (T, T), interpolation=cv2.INTER_AREA)

def shaded(name):
    h = height(name)
    mpp = 6000.0 / h.shape[0]
    gy, gx = np.gradient(h, mpp)
    light = np.clip(0.62 + (-gx - gy) * 0.55 / np.sqrt(1 + gx * gx + gy * gy), 0, 1)
    land_bgr, sea_bgr = np.array([70, 140, 105]), np.array([235, 190, 140])
    img = np.where((h > 0)[..., None], land_bgr * (0.45 + 0.9 * light)[..., None], sea_bgr * (0.85 + 0.15 * light)[..., None])
    return crop(np.clip(img, 0, 255).astype(np.uint8))

def painting(path):
    im = cv2.imread(path)
    return crop(cv2.resize(im, (1024, 1024), interpolation=cv2.INTER_NEAREST))

def titled(img, text):
    img = img.copy()
    cv2.putText(img, text, (8, 22), cv2.FONT_HERSHEY_SIMPLEX, 0.6, (0, 0, 0), 2)
    return img

top = [titled(painting(sketch), "painting")] + [titled(shaded(f"seed{s}"), f"--seed {s}") for s in (1, 2, 3)]
bottom = [titled(painting(f"{w}/pastel.png"), "west half pastel"), titled(shaded("pastel"), "--seed 1: smooth | rugged"),
          titled(shaded("seed1"), "full colour, --seed 1"), titled(shaded("model"), "256 answer, --seed 1")]
cv2.imwrite("docs/variations.png", np.vstack([np.hstack(top), np.hstack(bottom)]), [cv2.IMWRITE_PNG_COMPRESSION, 9])
EOF
echo docs/variations.png
