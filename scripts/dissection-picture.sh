#!/usr/bin/env bash
# Rebuilds docs/dissection.png (docs/REALISM.md "Age and dissection"): the
# young-volcano preset on a 24 km canvas (a 66 km² island) through
# `generate --size 1025` at --age-myr 0.25 / 1 / 5, hill-shaded, with the
# channels `realism --dissection` counts drawn in blue: every cell of its
# 30 m grid draining at least the island's slope–area break (read from the
# JSON). The drainage is traced again here (Priority-Flood + steepest
# descent, as terrain/dissection.cpp does), so a cell or two may differ.
# Needs python3-numpy and python3-opencv.
set -euo pipefail
cd "$(dirname "$0")/.."
R=build/cli/reefgen
W=$(mktemp -d); trap 'rm -rf "$W"' EXIT
python3 - "$W" <<'EOF'
import json, sys
j = json.load(open("configs/presets/young-volcano.json"))
j["world_size_m"] = 24000
json.dump(j, open(f"{sys.argv[1]}/wide.json", "w"))
EOF
for v in 0.25 1 5; do
  $R -q generate --spec "$W/wide.json" --size 1025 --age-myr "$v" -o "$W/age-$v" >/dev/null
  $R realism "$W/age-$v.height.exr" --dissection --json > "$W/age-$v.stats.json"
done
cat "$W"/*.stats.json
python3 - "$W" <<'EOF'
import heapq, json, os, sys
os.environ["OPENCV_IO_ENABLE_OPENEXR"] = "1"
import cv2, numpy as np
w = sys.argv[1]
CANVAS_M, GRID_M, T = 24000.0, 30.0, 420  # canvas, dissection grid, tile side px

def channels(h, threshold_m2):
    """Cells draining >= threshold_m2 on the filled surface (steepest descent)."""
    n = h.shape[0]
    land = h > 0
    filled = h.copy()
    done = ~land
    edge = land & (cv2.dilate((~land).astype(np.uint8), np.ones((3, 3), np.uint8)) > 0)
    queue = [(h[y, x], y, x) for y, x in zip(*np.nonzero(edge))]
    heapq.heapify(queue)
    done[edge] = True
    while queue:
        z, y, x = heapq.heappop(queue)
        for dy in (-1, 0, 1):
            for dx in (-1, 0, 1):
                yy, xx = y + dy, x + dx
                if 0 <= yy < n and 0 <= xx < n and not done[yy, xx]:
                    done[yy, xx] = True
                    filled[yy, xx] = max(h[yy, xx], z + 1e-4)
                    heapq.heappush(queue, (filled[yy, xx], yy, xx))
    pad = np.pad(filled, 1, constant_values=-1e9)
    best = np.zeros(h.shape)
    receiver = np.full(h.shape, -1, dtype=np.int64)
    index = np.arange(n * n).reshape(n, n)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            if dy == 0 and dx == 0:
                continue
            slope = (filled - pad[1 + dy:1 + dy + n, 1 + dx:1 + dx + n]) / np.hypot(dy, dx)
            neighbour = index[np.clip(np.arange(n) + dy, 0, n - 1)][:, np.clip(np.arange(n) + dx, 0, n - 1)]
            better = (slope > best) & land
            best[better], receiver[better] = slope[better], neighbour[better]
    area = np.where(land.ravel(), 1.0, 0.0) * (CANVAS_M / n) ** 2
    r = receiver.ravel()
    for i in np.argsort(-filled, axis=None):
        if r[i] >= 0:
            area[r[i]] += area[i]
    return (area.reshape(n, n) >= threshold_m2) & land

def tile(v):
    h = cv2.imread(f"{w}/age-{v}.height.exr", cv2.IMREAD_UNCHANGED)
    h = (h[:, :, 0] if h.ndim == 3 else h).astype(np.float64)
    n = int(round(CANVAS_M / GRID_M))
    g = cv2.resize(h, (n, n), interpolation=cv2.INTER_AREA)
    d = json.load(open(f"{w}/age-{v}.stats.json"))["dissection"]
    ch = channels(g, d["channel_threshold_m2"]) if d["channel_threshold_m2"] > 0 else np.zeros(g.shape, bool)
    gy, gx = np.gradient(h, CANVAS_M / h.shape[0])
    light = np.clip(0.62 + (-gx - gy) * 0.55 / np.sqrt(1 + gx * gx + gy * gy), 0, 1)
    img = np.where((h > 0)[..., None], np.array([225, 225, 225]) * (0.2 + 0.9 * light)[..., None],
                   np.array([150, 100, 45]) * (0.75 + 0.4 * light)[..., None])
    img = np.clip(img, 0, 255).astype(np.uint8)
    big = cv2.resize(ch.astype(np.uint8), (h.shape[1], h.shape[0]), interpolation=cv2.INTER_NEAREST) > 0
    img[big] = (200, 60, 0)
    a = h.shape[0] // 6
    img = cv2.resize(img[a:-a, a:-a], (T, T), interpolation=cv2.INTER_AREA)
    lines = [f"--age-myr {v}: {d['drainage_density_per_km']:.2f} km/km2",
             f"channels from {d['channel_threshold_m2'] / 1e4:.0f} ha, {100 * d['land_above_half_peak']:.0f} % above half"]
    for k, text in enumerate(lines):
        cv2.putText(img, text, (6, 16 + 16 * k), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (0, 0, 160), 1, cv2.LINE_AA)
    return img

cv2.imwrite("docs/dissection.png", np.hstack([tile(v) for v in ("0.25", "1", "5")]), [cv2.IMWRITE_PNG_COMPRESSION, 9])
EOF
echo docs/dissection.png
