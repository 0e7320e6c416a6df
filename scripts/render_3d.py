#!/usr/bin/env python3
"""A 3D view of a height field for the docs: voxel-space ray casting (one ray
per screen column, front to back, a y-buffer keeps what is in front) coloured
by reefgen's hill-shaded preview. Needs only numpy and OpenCV (Debian:
python3-numpy python3-opencv).

  python3 scripts/render_3d.py out/island.height.exr out/island.preview.png out/island-3d.png \
      [--width 1200] [--height 700] [--exaggeration 2] [--azimuth 200]
"""
import argparse
import os

os.environ.setdefault("OPENCV_IO_ENABLE_OPENEXR", "1")
import cv2  # noqa: E402
import numpy as np  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("height")
    ap.add_argument("colour")
    ap.add_argument("out")
    ap.add_argument("--width", type=int, default=1200)
    ap.add_argument("--height-px", dest="height_px", type=int, default=700)
    ap.add_argument("--exaggeration", type=float, default=2.0)
    ap.add_argument("--azimuth", type=float, default=200.0, help="camera direction, degrees (0 = looking north)")
    ap.add_argument("--world-size", type=float, default=6000.0, help="canvas width in metres")
    a = ap.parse_args()

    h = cv2.imread(a.height, cv2.IMREAD_UNCHANGED).astype(np.float32)
    col = cv2.imread(a.colour, cv2.IMREAD_COLOR)
    n = h.shape[0]
    if col.shape[:2] != h.shape:
        col = cv2.resize(col, (h.shape[1], h.shape[0]), interpolation=cv2.INTER_AREA)
    mpp = a.world_size / n
    hz = np.maximum(h, -60.0) * a.exaggeration / mpp  # heights in cells; the deep sea floor flattened
    W, H = a.width, a.height_px
    img = np.zeros((H, W, 3), np.uint8)
    img[:] = (235, 225, 215)  # sky (BGR)
    ybuf = np.full(W, H, np.int32)
    az = np.radians(a.azimuth)
    fwd = np.array([np.sin(az), -np.cos(az)])
    right = np.array([np.cos(az), np.sin(az)])
    centre = np.array([n / 2, n / 2])
    cam = centre - fwd * n * 0.5
    cam_h = hz.max() * 1.25 + n * 0.1
    horizon = H * 0.22
    scale = H * 0.9
    xs = (np.arange(W) - W / 2) / (W / 2)  # -1..1 across the screen
    steps = int(n * 1.9)
    for k in range(1, steps):
        z = k * 1.0 * (1 + k / steps)  # finer steps near the camera
        if z > n * 1.9:
            break
        px = cam[0] + fwd[0] * z + right[0] * xs * z * 0.75
        py = cam[1] + fwd[1] * z + right[1] * xs * z * 0.75
        inside = (px >= 0) & (px < n - 1) & (py >= 0) & (py < n - 1)
        if not inside.any():
            continue
        ix = np.clip(px.astype(np.int32), 0, n - 1)
        iy = np.clip(py.astype(np.int32), 0, n - 1)
        hh = np.where(inside, hz[iy, ix], -1e9)
        ys = ((cam_h - hh) / z * scale * 0.5 + horizon).astype(np.int32)
        ys = np.clip(ys, 0, H)
        draw = inside & (ys < ybuf)
        if not draw.any():
            continue
        c = col[iy, ix]
        fog = min(0.45, z / (n * 1.9) * 0.5)
        c = (c * (1 - fog) + np.array([235, 225, 215]) * fog).astype(np.uint8)
        for x in np.nonzero(draw)[0]:
            img[ys[x]:ybuf[x], x] = c[x]
        ybuf = np.where(draw, ys, ybuf)
    cv2.imwrite(a.out, img, [cv2.IMWRITE_PNG_COMPRESSION, 9])


if __name__ == "__main__":
    main()
