#!/usr/bin/env bash
# Rebuilds docs/shipped.png: four painted sketches (tests/data/painted), the
# shipped model's 256² answer, the same sketch through `infer --size 1025`
# (amplified, docs/EROSION.md) and a crop of it at 1:1. Needs python3-numpy and
# python3-opencv. MODEL=path overrides the model (default: the shipped one).
set -euo pipefail
export OPENCV_IO_ENABLE_OPENEXR=1
cd "$(dirname "$0")/.."
R=build/cli/reefgen
M=${MODEL:-models/reef-256.pt}
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
S="01-young-volcano 03-two-islands 06-long-arc 14-three-ages"
for s in $S; do
  $R -q infer "tests/data/painted/$s.png" -m "$M" -o "$W/$s-256" --preview >/dev/null
  $R -q infer "tests/data/painted/$s.png" -m "$M" -o "$W/$s-1025" --size 1025 --preview >/dev/null
done
python3 - "$W" $S <<'PY'
import sys, cv2, numpy as np
w, names = sys.argv[1], sys.argv[2:]
side = 300
rows = []
for n in names:
    sk = cv2.resize(cv2.imread(f"tests/data/painted/{n}.png"), (side, side), interpolation=cv2.INTER_AREA)
    a = cv2.resize(cv2.imread(f"{w}/{n}-256.preview.png"), (side, side), interpolation=cv2.INTER_LINEAR)
    big = cv2.imread(f"{w}/{n}-1025.preview.png")
    b = cv2.resize(big, (side, side), interpolation=cv2.INTER_AREA)
    # 1:1 crop on the upper flanks: the median position of the land above
    # half the highest height (on an arc that stays on the ridge)
    h = cv2.imread(f"{w}/{n}-1025.height.exr", cv2.IMREAD_UNCHANGED)
    ys, xs = np.nonzero(h > 0.5 * h.max())
    cy, cx = int(np.median(ys)), int(np.median(xs))
    y0 = min(max(cy - side // 2, 0), big.shape[0] - side)
    x0 = min(max(cx - side // 2, 0), big.shape[1] - side)
    c = big[y0:y0 + side, x0:x0 + side].copy()
    s = side / big.shape[0]
    cv2.rectangle(b, (int(x0 * s), int(y0 * s)), (int((x0 + side) * s), int((y0 + side) * s)), (0, 0, 255), 1)
    rows.append(np.hstack([sk, a, b, c]))
img = np.vstack(rows)
for i, t in enumerate(["sketch", "256 answer", "--size 1025", "1025 crop 1:1"]):
    cv2.putText(img, t, (8 + i * side, 22), cv2.FONT_HERSHEY_SIMPLEX, 0.6, (255, 255, 255), 2)
cv2.imwrite("docs/shipped.png", img, [cv2.IMWRITE_PNG_COMPRESSION, 9])
PY
echo docs/shipped.png
