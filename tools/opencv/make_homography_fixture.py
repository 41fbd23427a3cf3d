#!/usr/bin/env python3
"""Writes OpenCV's getPerspectiveTransform and findHomography results as a glint test fixture.

Usage: python3 tools/opencv/make_homography_fixture.py > tools/opencv/fixtures/homography.txt

Format, one record a line, numbers separated by spaces:
  four  sx0 sy0 .. sx3 sy3  dx0 dy0 .. dx3 dy3  h00 h01 h02 h10 h11 h12 h20 h21 h22
  fit   N  sx0 sy0 .. (N pairs)  dx0 dy0 ..  h00 .. h22
'four' comes from cv2.getPerspectiveTransform(src, dst), 'fit' from cv2.findHomography(src, dst, 0)
(plain least squares over all points).
"""
import numpy as np
import cv2

rng = np.random.default_rng(4)


def fmt(values):
    return " ".join(repr(float(v)) for v in values)


# The seed's own case: a 20 cm marker's floor corners and a plausible view of them.
cases = [
    (np.float32([[20, 0], [20, 20], [0, 20], [0, 0]]),
     np.float32([[352.4, 301.7], [371.9, 345.2], [301.3, 349.8], [290.6, 305.1]])),
]
for _ in range(4):
    src = np.float32([[0, 0], [1, 0], [1, 1], [0, 1]]) * rng.uniform(10, 50) + rng.uniform(-50, 50, 2)
    dst = (src * rng.uniform(2, 8) + rng.uniform(100, 300, 2) + rng.normal(0, 6, (4, 2))).astype(np.float32)
    cases.append((src.astype(np.float32), dst))
for src, dst in cases:
    m = cv2.getPerspectiveTransform(src, dst)
    print("four", fmt(src.flatten()), fmt(dst.flatten()), fmt(m.flatten()))

for n in (8, 20):
    h_true = np.array([[2.1, 0.3, 320.0], [-0.2, 1.4, 240.0], [0.0004, 0.0021, 1.0]])
    src = rng.uniform(-100, 100, (n, 2))
    p = np.c_[src, np.ones(n)] @ h_true.T
    dst = p[:, :2] / p[:, 2:] + rng.normal(0, 0.5, (n, 2))
    m, _ = cv2.findHomography(src, dst, 0)
    print("fit", n, fmt(src.flatten()), fmt(dst.flatten()), fmt(m.flatten()))
