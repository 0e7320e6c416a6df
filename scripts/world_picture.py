#!/usr/bin/env python3
"""docs/world.png: a world's overview beside a 1:1 crop round its summit.

usage: OPENCV_IO_ENABLE_OPENEXR=1 /usr/bin/python3 scripts/world_picture.py WORLD.height.exr OUT.png
(the cell size is read from the EXR's reefgen:metres_per_pixel; pass it as a
third argument for a file without it)."""
import sys
import cv2
import numpy as np


def shaded(h, mpp):
    gy, gx = np.gradient(h.astype(np.float32), mpp)
    # light from the north-west, 45° up
    n = np.dstack([-gx, -gy, np.ones_like(h)])
    n /= np.linalg.norm(n, axis=2, keepdims=True)
    light = np.array([-1.0, -1.0, 1.4]) / np.linalg.norm([-1.0, -1.0, 1.4])
    shade = np.clip(n @ light, 0, 1)
    land = np.clip(h / max(h.max(), 1), 0, 1)[..., None]
    sea = np.clip(1 + h / 100, 0, 1)[..., None]
    lo, hi = np.array([70, 150, 60]), np.array([140, 185, 215])            # BGR green to tan
    deep, shallow = np.array([110, 60, 25]), np.array([215, 190, 90])
    c = np.where(h[..., None] > 0, (lo + (hi - lo) * land) * (0.35 + 0.9 * shade[..., None]),
                 deep + (shallow - deep) * sea)
    return np.clip(c, 0, 255).astype(np.uint8)


h = cv2.imread(sys.argv[1], cv2.IMREAD_UNCHANGED)
mpp = float(sys.argv[3]) if len(sys.argv) > 3 else 2.93
side = 720
small = cv2.resize(h, (side, side * h.shape[0] // h.shape[1]), interpolation=cv2.INTER_AREA)
over = shaded(small, mpp * h.shape[1] / side)
y, x = np.unravel_index(np.argmax(cv2.GaussianBlur(small, (0, 0), 5)), small.shape)
cy, cx = int(y * h.shape[0] / small.shape[0]), int(x * h.shape[1] / small.shape[1])
half = side // 2
cy, cx = np.clip(cy, half, h.shape[0] - half), np.clip(cx, half, h.shape[1] - half)
crop = shaded(h[cy - half:cy + half, cx - half:cx + half], mpp)
s = side / h.shape[1]
cv2.rectangle(over, (int((cx - half) * s), int((cy - half) * s)), (int((cx + half) * s), int((cy + half) * s)), (0, 0, 255), 2)
pad = np.full((over.shape[0], 12, 3), 255, np.uint8)
cv2.imwrite(sys.argv[2], np.hstack([over, pad, crop[:over.shape[0]]]))
