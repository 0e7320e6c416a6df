#!/usr/bin/python3
"""Paints docs/examples/floating-painting.png, the example painting of
`reefgen floating` (a top view: green top with snow, brown rock below, sky)."""
import sys
import cv2
import numpy as np

out = sys.argv[1] if len(sys.argv) > 1 else "docs/examples/floating-painting.png"
W = 256
sky, green, brown, white = (235, 206, 135), (80, 175, 76), (43, 90, 139), (255, 255, 255)  # BGR
img = np.full((W, W, 3), sky, np.uint8)
# The rock hanging below the top, drawn first (the top covers its upper part).
rock = np.array([[70, 110], [186, 110], [170, 170], [140, 215], [122, 238], [104, 200], [84, 160]], np.int32)
cv2.fillPoly(img, [rock], brown, cv2.LINE_AA)
# The top: a lobed outline (a large lobe, a smaller one, a bay between).
cv2.ellipse(img, (118, 96), (82, 50), -8, 0, 360, green, -1, cv2.LINE_AA)
cv2.ellipse(img, (182, 122), (44, 34), 20, 0, 360, green, -1, cv2.LINE_AA)
cv2.circle(img, (150, 60), 14, sky, -1, cv2.LINE_AA)  # a bay
# Snow on the high ground.
cv2.ellipse(img, (100, 88), (22, 14), 15, 0, 360, white, -1, cv2.LINE_AA)
cv2.imwrite(out, img)
print(out)
