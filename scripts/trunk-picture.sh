#!/usr/bin/env bash
# Draws docs/trunk.png: the young-volcano preset's seeds 1 and 2 at 1025²,
# hill-shaded at one scale: the comb (no shield, no trunk grid), the shield
# alone (noise.shield 0.5, trunk_px 0: the generator before the trunk
# basins) and today's defaults (docs/EROSION.md "Trunk basins"), beside a
# real island when a DEM is given (a float32 EXR or .npy in metres with its
# cell size, e.g. Kauaʻi from SRTM at 90 m).
#   bash scripts/trunk-picture.sh [OUT.png] [DEM CELL_M]
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-docs/trunk.png}
dem=${2:-}
cell=${3:-90}
bin=build/cli/reefgen
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
spec() {  # spec OUT.json SHIELD TRUNK_PX
  /usr/bin/python3 -c "import json,sys; d=json.load(open('configs/presets/young-volcano.json')); d.setdefault('noise',{})['shield']=float(sys.argv[2]); d.setdefault('erosion',{})['trunk_px']=int(sys.argv[3]); json.dump(d,open(sys.argv[1],'w'))" "$@"
}
spec "$work/comb.json" 0 0
spec "$work/shield.json" 0.5 0
for seed in 1 2; do
  "$bin" -q generate --spec "$work/comb.json" --seed "$seed" --size 1025 -o "$work/comb$seed" >/dev/null
  "$bin" -q generate --spec "$work/shield.json" --seed "$seed" --size 1025 -o "$work/shield$seed" >/dev/null
  "$bin" -q generate --preset young-volcano --seed "$seed" --size 1025 -o "$work/trunk$seed" >/dev/null
done
OPENCV_IO_ENABLE_OPENEXR=1 /usr/bin/python3 - "$work" "$out" "$dem" "$cell" <<'PY'
import sys, cv2, numpy as np
work, out, dem, cell = sys.argv[1], sys.argv[2], sys.argv[3], float(sys.argv[4])
def shade(h, mpp, side=420):
    land = h > 0
    ys, xs = np.nonzero(land)
    pad = int(0.08 * max(np.ptp(ys), np.ptp(xs)))
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
    cv2.putText(img, text, (8, 20), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 0, 255), 1, cv2.LINE_AA)
    return img
rows = []
for kind, name in (("comb", "no shield, no trunk"), ("shield", "shield 0.5, no trunk (before)"), ("trunk", "trunk basins (now)")):
    rows.append(np.hstack([label(shade(cv2.imread(f"{work}/{kind}{s}.height.exr", cv2.IMREAD_UNCHANGED), 6000 / 1025),
                                 f"seed {s}: {name}") for s in (1, 2)]))
if dem:
    h = np.load(dem).astype(np.float32) if dem.endswith(".npy") else cv2.imread(dem, cv2.IMREAD_UNCHANGED).astype(np.float32)
    k = label(shade(h, cell), f"real: {dem.split('/')[-1].split('.')[0]} (SRTM, {cell:g} m)")
    rows = [np.hstack([rows[0], k])] + [np.hstack([r, np.full_like(k, 90)]) for r in rows[1:]]
cv2.imwrite(out, np.vstack(rows))
print(out)
PY
