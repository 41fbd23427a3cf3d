#!/usr/bin/env python3
"""Marker images made and detected by OpenCV, as fixtures for glint's detector.

Usage: python3 tools/opencv/make_marker_fixtures.py   (needs opencv-contrib-python-headless)

For each case it writes tools/opencv/fixtures/<name>.pgm (8-bit luma) and <name>.txt:
  dict DICT_NAME
  marker ID x0 y0 x1 y1 x2 y2 x3 y3      (OpenCV's detectMarkers corners, sub-pixel refined)
  truth ID x0 y0 x1 y1 x2 y2 x3 y3       (where the marker's outer corners were drawn)
Markers come from cv2.aruco.generateImageMarker, are warped by a perspective transform onto a
light background, blurred slightly and given noise, so the detector sees camera-like edges.
"""
import pathlib

import cv2
import numpy as np

OUT = pathlib.Path(__file__).resolve().parent / "fixtures"
rng = np.random.default_rng(44)

# name, dictionary, image size, [(id, marker side px before warp, destination quad)]
CASES = [
    ("dict_4x4_50", "DICT_4X4_50", (128, 96), [(7, 60, [[30, 14], [98, 22], [92, 84], [24, 76]])]),
    ("dict_5x5_100", "DICT_5X5_100", (128, 96), [(42, 70, [[96, 18], [100, 80], [30, 84], [26, 12]])]),
    ("dict_6x6_250", "DICT_6X6_250", (216, 112), [
        (3, 80, [[14, 20], [84, 12], [88, 92], [20, 98]]),
        (211, 80, [[194, 52], [150, 96], [124, 54], [166, 14]]),
    ]),
    ("dict_7x7_250", "DICT_7X7_250", (128, 112), [(99, 90, [[20, 12], [110, 20], [104, 100], [14, 94]])]),
    ("dict_apriltag_36h11", "DICT_APRILTAG_36h11", (128, 112), [(586, 80, [[22, 96], [18, 18], [104, 12], [108, 100]])]),
]


def render(dictionary, size, markers):
    w, h = size
    image = np.full((h, w), 225.0)
    for marker_id, side, quad in markers:
        margin = side // 4
        tile = np.full((side + 2 * margin, side + 2 * margin), 255, np.uint8)
        tile[margin:margin + side, margin:margin + side] = cv2.aruco.generateImageMarker(dictionary, marker_id, side)
        s = float(side)
        # Map the marker's own corners (pixel-edge coordinates) onto the quad.
        src = np.float32([[margin, margin], [margin + s, margin], [margin + s, margin + s], [margin, margin + s]]) - 0.5
        m = cv2.getPerspectiveTransform(src, np.float32(quad))
        warped = cv2.warpPerspective(tile.astype(np.float32), m, (w, h), flags=cv2.INTER_AREA, borderValue=-1)
        mask = warped >= 0
        image[mask] = warped[mask] * 0.85 + 15
    image = cv2.GaussianBlur(image, (0, 0), 0.6)
    image += rng.normal(0, 2.0, image.shape)
    return np.clip(np.rint(image), 0, 255).astype(np.uint8)


def main():
    OUT.mkdir(exist_ok=True)
    for name, dict_name, size, markers in CASES:
        dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, dict_name))
        image = render(dictionary, size, markers)
        params = cv2.aruco.DetectorParameters()
        params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
        detector = cv2.aruco.ArucoDetector(dictionary, params)
        corners, ids, _ = detector.detectMarkers(image)
        found = sorted(int(i) for i in (ids.flatten() if ids is not None else []))
        want = sorted(m[0] for m in markers)
        assert found == want, f"{name}: OpenCV found {found}, placed {want}"
        cv2.imwrite(str(OUT / f"{name}.pgm"), image)
        lines = [f"dict {dict_name}"]
        for c, i in sorted(zip(corners, ids.flatten()), key=lambda t: int(t[1])):
            lines.append(f"marker {int(i)} " + " ".join(f"{v:.4f}" for v in c.reshape(-1)))
        for marker_id, _, quad in sorted(markers):
            lines.append(f"truth {marker_id} " + " ".join(f"{v:.4f}" for v in np.float32(quad).reshape(-1)))
        (OUT / f"{name}.txt").write_text("\n".join(lines) + "\n")
        print(name, lines[1:])


if __name__ == "__main__":
    main()
