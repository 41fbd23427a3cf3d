#!/usr/bin/env python3
"""Writes OpenCV's lens model (projectPoints, undistortPoints) as a glint test fixture.

Usage: python3 tools/opencv/make_lens_fixture.py > tools/opencv/fixtures/lens.txt

Format, one record a line, numbers separated by spaces:
  lens     fx fy cx cy k1 k2 p1 p2 k3          (the lens of the lines that follow)
  project  x y z  u v                         cv2.projectPoints of (x, y, z), no rotation or shift
  undist   u v  x y                           cv2.undistortPoints with a 200-step, 1e-14 criterion: the ray (x, y, 1)
"""
import numpy as np
import cv2

rng = np.random.default_rng(12)


def fmt(values):
    return " ".join(repr(float(v)) for v in values)


lenses = [
    # The wide-angle webcam of the accuracy targets.
    (460.0, 460.0, 319.5, 239.5, -0.30, 0.09, 0.0, 0.0, 0.0),
    # A milder, decentred lens.
    (455.0, 462.0, 325.5, 235.5, -0.12, 0.0, 0.001, -0.001, 0.0),
    # All five coefficients.
    (610.0, 605.0, 318.0, 244.0, -0.21, 0.05, -0.0012, 0.0008, 0.012),
]
for fx, fy, cx, cy, k1, k2, p1, p2, k3 in lenses:
    k = np.array([[fx, 0, cx], [0, fy, cy], [0, 0, 1]], dtype=np.float64)
    d = np.array([k1, k2, p1, p2, k3], dtype=np.float64)
    print("lens", fmt([fx, fy, cx, cy, k1, k2, p1, p2, k3]))
    pts = np.c_[rng.uniform(-0.65, 0.65, (8, 2)), rng.uniform(50, 300, 8)]
    pts[:, :2] *= pts[:, 2:]
    img, _ = cv2.projectPoints(pts, np.zeros(3), np.zeros(3), k, d)
    for p, q in zip(pts, img.reshape(-1, 2)):
        print("project", fmt(p), fmt(q))
    px = np.c_[rng.uniform(0, 639, 8), rng.uniform(0, 479, 8)]
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-14)
    und = cv2.undistortPoints(px.reshape(-1, 1, 2), k, d, R=None, P=None, criteria=criteria)
    for p, q in zip(px, und.reshape(-1, 2)):
        print("undist", fmt(p), fmt(q))
