#!/usr/bin/env bash
# Rebuilds docs/realism-1025.png and docs/realism-4097.png: the young-volcano
# preset generated at 1025² and 4097², hill-shaded (whole island + a crop) and
# in 3D (scripts/render_3d.py). Needs python3-numpy and python3-opencv.
set -euo pipefail
cd "$(dirname "$0")/.."
R=build/cli/reefgen
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
for n in 1025 4097; do
  $R -q generate --preset young-volcano --size $n -o "$W/yv$n" --preview >/dev/null
  python3 scripts/render_3d.py "$W/yv$n.height.exr" "$W/yv$n.preview.png" "$W/yv$n-3d.png" --width 900 --height-px 500
done
python3 - "$W" <<'EOF'
import sys, cv2, numpy as np
w = sys.argv[1]
def panel(n, crop, side, out, title):
    p = cv2.imread(f"{w}/yv{n}.preview.png")
    full = cv2.resize(p, (500, 500), interpolation=cv2.INTER_AREA)
    y0, x0 = crop
    c = cv2.resize(p[y0:y0 + side, x0:x0 + side], (500, 500), interpolation=cv2.INTER_NEAREST)
    s = 500 / p.shape[0]
    cv2.rectangle(full, (int(x0 * s), int(y0 * s)), (int((x0 + side) * s), int((y0 + side) * s)), (0, 0, 255), 2)
    d = cv2.imread(f"{w}/yv{n}-3d.png")
    d = cv2.resize(d, (1000, int(d.shape[0] * 1000 / d.shape[1])), interpolation=cv2.INTER_AREA)
    img = np.vstack([np.hstack([full, c]), d])
    cv2.putText(img, title, (10, 25), cv2.FONT_HERSHEY_SIMPLEX, 0.7, (255, 255, 255), 2)
    cv2.imwrite(out, img, [cv2.IMWRITE_PNG_COMPRESSION, 9])
panel(1025, (330, 300), 250, "docs/realism-1025.png", "young-volcano, 1025^2 (crop: 250 px, x2)")
panel(4097, (1400, 1300), 500, "docs/realism-4097.png", "young-volcano, 4097^2 (crop: 500 px at 1:1)")
EOF
echo "docs/realism-1025.png docs/realism-4097.png"
