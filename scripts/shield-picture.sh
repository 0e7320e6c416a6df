#!/usr/bin/env bash
# Draws docs/shield.png: the young-volcano preset's seeds 1 and 2 at 1025²
# without the shield (noise.shield 0: the comb) and with it (the default),
# hill-shaded beside a real island when a DEM is given (Kauaʻi from SRTM,
# a float32 EXR in metres with its cell size).
#   bash scripts/shield-picture.sh [OUT.png] [DEM.exr CELL_M]
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-docs/shield.png}
dem=${2:-}
cell=${3:-90}
bin=build/cli/reefgen
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for seed in 1 2; do
  /usr/bin/python3 -c "import json,sys; d=json.load(open('configs/presets/young-volcano.json')); d.setdefault('noise',{})['shield']=0; json.dump(d,open(sys.argv[1],'w'))" "$work/comb.json"
  "$bin" -q generate --spec "$work/comb.json" --seed "$seed" --size 1025 -o "$work/comb$seed" >/dev/null
  "$bin" -q generate --preset young-volcano --seed "$seed" --size 1025 -o "$work/shield$seed" >/dev/null
done
OPENCV_IO_ENABLE_OPENEXR=1 /usr/bin/python3 - "$work" "$out" "$dem" "$cell" <<'PY'
import sys, cv2, numpy as np
work, out, dem, cell = sys.argv[1], sys.argv[2], sys.argv[3], float(sys.argv[4])
def shade(h, mpp, side=512):
    land = h > 0
    ys, xs = np.nonzero(land)
    pad = int(0.08 * max(ys.ptp(), xs.ptp()))
    h = h[max(ys.min() - pad, 0):ys.max() + pad, max(xs.min() - pad, 0):xs.max() + pad]
    gy, gx = np.gradient(h, mpp)
    n = np.dstack([-gx, -gy, np.ones_like(h)]); n /= np.linalg.norm(n, axis=2, keepdims=True)
    l = np.array([-1, -1, 1.5]); l = l / np.linalg.norm(l)
    s = np.clip(n @ l, 0, 1)
    s = np.where(h > 0, s, 0.35 + 0.1 * s)
    img = (255 * s).astype(np.uint8)
    f = side / max(img.shape)
    img = cv2.resize(img, None, fx=f, fy=f, interpolation=cv2.INTER_AREA)
    canvas = np.full((side, side), 90, np.uint8)
    canvas[:img.shape[0], :img.shape[1]] = img
    return cv2.cvtColor(canvas, cv2.COLOR_GRAY2BGR)
def label(img, text):
    cv2.putText(img, text, (8, 22), cv2.FONT_HERSHEY_SIMPLEX, 0.6, (0, 0, 255), 1, cv2.LINE_AA)
    return img
tiles = []
for kind, name in (("comb", "no shield"), ("shield", "shield")):
    for seed in (1, 2):
        h = cv2.imread(f"{work}/{kind}{seed}.height.exr", cv2.IMREAD_UNCHANGED)
        tiles.append(label(shade(h, 6000 / 1025), f"young-volcano seed {seed}, {name}"))
rows = [np.hstack(tiles[:2]), np.hstack(tiles[2:])]
if dem:
    h = cv2.imread(dem, cv2.IMREAD_UNCHANGED).astype(np.float32)
    k = label(shade(h, cell), "Kauai (SRTM, 90 m)")
    rows = [np.hstack([rows[0], k]), np.hstack([rows[1], np.full_like(k, 90)])]
cv2.imwrite(out, np.vstack(rows))
print(out)
PY
