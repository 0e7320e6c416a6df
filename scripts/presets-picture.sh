#!/usr/bin/env bash
# Rebuilds docs/presets.png (README): the five presets of `reefgen presets`
# through `generate --size 1025 --preview` (hill-shaded colours), each
# tile the canvas's central 5.4 km at 300 px, titled with its name.
# Needs python3-numpy and python3-opencv.
set -euo pipefail
cd "$(dirname "$0")/.."
R=build/cli/reefgen
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
P="young-volcano barrier-reef atoll low-island windswept"
for p in $P; do $R -q generate --preset "$p" --size 1025 --preview -o "$W/$p" >/dev/null; done
python3 - "$W" $P <<'EOF'
import sys
import cv2, numpy as np
w, names = sys.argv[1], sys.argv[2:]
T = 300  # tile side, px

def tile(name):
    img = cv2.imread(f"{w}/{name}.preview.png")
    n = img.shape[0]
    a = n // 20
    img = cv2.resize(img[a:n - a, a:n - a], (T, T), interpolation=cv2.INTER_AREA)
    cv2.putText(img, name, (8, 20), cv2.FONT_HERSHEY_SIMPLEX, 0.55, (255, 255, 255), 1, cv2.LINE_AA)
    return img

cv2.imwrite("docs/presets.png", np.hstack([tile(n) for n in names]), [cv2.IMWRITE_PNG_COMPRESSION, 9])
EOF
echo docs/presets.png
