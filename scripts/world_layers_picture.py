#!/usr/bin/env python3
"""docs/world-layers.png: a world's materials from its layer tiles (PREFIX.layers/,
docs/WORLDS.md "Layers and bundles in tiles"): the whole world with its tile
grid, a 1:1 crop round the tile corner with the most land, and the flow
layer of that crop.

usage: /usr/bin/python3 scripts/world_layers_picture.py PREFIX OUT.png
(PREFIX.json names the tiles; made by `reefgen world ... --layers` past 8192²)."""
import json
import os
import sys

import cv2
import numpy as np

prefix, out = sys.argv[1], sys.argv[2]
side = json.load(open(prefix + ".json"))
L = side["layers"]
W, H = side["size_px"]
tw, th = L["tile_px"]
folder = prefix + ".layers"
overview_px = 960
f = overview_px / max(W, H)
over = np.zeros((int(round(H * f)), int(round(W * f)), 3), np.uint8)
crop_px = 640


def tile_image(t, kind, flags=cv2.IMREAD_COLOR):
    return cv2.imread(os.path.join(folder, t["files"][kind]), flags)


# Overview: each tile's materials shrunk into place.
land_near = {}
for t in L["layer_tiles"]:
    im = tile_image(t, "materials")
    x0, y0 = t["x"] * tw, t["y"] * th
    a, b = int(round(x0 * f)), int(round(y0 * f))
    c, d = int(round((x0 + im.shape[1]) * f)), int(round((y0 + im.shape[0]) * f))
    over[b:d, a:c] = cv2.resize(im, (c - a, d - b), interpolation=cv2.INTER_AREA)
# The interior tile corner with the most land (not deep sea blue) round it.
best, corner = -1, (tw, th)
sea = np.array([92, 52, 32])
for j in range(1, L["tiles_per_axis"][1]):
    for i in range(1, L["tiles_per_axis"][0]):
        x, y = int(i * tw * f), int(j * th * f)
        patch = over[max(0, y - 20):y + 20, max(0, x - 20):x + 20].astype(int)
        land = (np.abs(patch - sea).sum(2) > 60).mean()
        if land > best:
            best, corner = land, (i * tw, j * th)
# Crops at 1:1 from the four tiles round that corner.
cx, cy = corner
crop = np.zeros((crop_px, crop_px, 3), np.uint8)
flow = np.zeros((crop_px, crop_px), np.uint16)
for t in L["layer_tiles"]:
    x0, y0 = t["x"] * tw, t["y"] * th
    ox, oy = cx - crop_px // 2, cy - crop_px // 2
    im = tile_image(t, "materials")
    fl = tile_image(t, "flow", cv2.IMREAD_UNCHANGED)
    ax, ay = max(ox, x0), max(oy, y0)
    bx, by = min(ox + crop_px, x0 + im.shape[1]), min(oy + crop_px, y0 + im.shape[0])
    if ax >= bx or ay >= by:
        continue
    crop[ay - oy:by - oy, ax - ox:bx - ox] = im[ay - y0:by - y0, ax - x0:bx - x0]
    flow[ay - oy:by - oy, ax - ox:bx - ox] = fl[ay - y0:by - y0, ax - x0:bx - x0]
flow_bgr = cv2.applyColorMap((flow >> 8).astype(np.uint8), cv2.COLORMAP_OCEAN)
flow_bgr[flow == 0] = (40, 30, 20)
# Tile grid on the overview, the crop's square in red.
for i in range(1, L["tiles_per_axis"][0]):
    over[:, int(i * tw * f)] = over[:, int(i * tw * f)] // 2 + 100
for j in range(1, L["tiles_per_axis"][1]):
    over[int(j * th * f), :] = over[int(j * th * f), :] // 2 + 100
cv2.rectangle(over, (int((cx - crop_px / 2) * f), int((cy - crop_px / 2) * f)),
              (int((cx + crop_px / 2) * f), int((cy + crop_px / 2) * f)), (0, 0, 255), 2)
scale = over.shape[0] / crop_px
right = np.vstack([cv2.resize(crop, None, fx=scale / 2, fy=scale / 2, interpolation=cv2.INTER_AREA),
                   cv2.resize(flow_bgr, None, fx=scale / 2, fy=scale / 2, interpolation=cv2.INTER_AREA)])
right = cv2.resize(right, (right.shape[1], over.shape[0]))
cv2.imwrite(out, np.hstack([over, right]))
