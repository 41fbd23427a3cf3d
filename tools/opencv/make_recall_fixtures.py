#!/usr/bin/env python3
"""Hard marker images and OpenCV's own detections in them, for glint's recall tests.

Usage: python3 tools/opencv/make_recall_fixtures.py [path/to/singlemarkersoriginal.jpg]
(choriginal.jpg, the ChArUco photo, is taken from the same folder)
(needs opencv-contrib-python-headless and numpy; the photo comes from Debian's opencv-doc package:
`apt-get download opencv-doc && dpkg-deb -x opencv-doc_*.deb x`, then
x/usr/share/doc/opencv-doc/opencv4/html/singlemarkersoriginal.jpg).

For each case it writes tools/opencv/fixtures/recall/<name>.png (8-bit luma) and <name>.txt:
  dict DICT_NAME
  placed ID x0 y0 .. x3 y3     where a marker's outer corners were drawn (synthetic cases only)
  opencv ID x0 y0 .. x3 y3     ArucoDetector with default parameters (no corner refinement)
  subpix ID x0 y0 .. x3 y3     the same with CORNER_REFINE_SUBPIX (cornerSubPix)
  contour ID x0 y0 .. x3 y3    the same with CORNER_REFINE_CONTOUR (OpenCV's second refinement)
Corners are top-left, top-right, bottom-right, bottom-left as printed, pixel centres at integers.

The cases are the ones where glint's detector used to miss markers that OpenCV finds: a
studio-range camera, low-contrast and grey-ink prints, small and steeply foreshortened markers,
and barrel distortion. Each synthetic image is rendered by warping OpenCV's generateImageMarker
tiles (with a white margin) onto a background, then blurred and given noise.
"""
import pathlib
import sys

import cv2
import numpy as np

OUT = pathlib.Path(__file__).resolve().parent / "fixtures" / "recall"
rng = np.random.default_rng(11)


def square_quad(cx, cy, side, angle_deg, squash=1.0, tilt=0.0):
    """A square of `side` px turned by `angle_deg`, then squashed vertically by `squash` (a
    foreshortening) with `tilt` extra perspective: the far (top) edge shorter by that share."""
    a = np.deg2rad(angle_deg)
    rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    h = side / 2.0
    pts = np.array([[-h, -h], [h, -h], [h, h], [-h, h]]) @ rot.T
    pts[:, 1] /= squash
    # Perspective: points higher up the picture (farther away) come closer together.
    scale = 1.0 - tilt * (0.5 - (pts[:, 1] + h) / (2 * h))
    pts[:, 0] *= scale
    return (pts + [cx, cy]).tolist()


def render(dictionary, size, markers, paper, ink, background, noise, blur, gradient=0.0):
    """Markers as (id, quad) on `background`, ink and paper levels as given, lit by a left-to-right
    gradient (`gradient` is the share of light lost at the right edge)."""
    w, h = size
    image = np.full((h, w), float(background))
    # A little texture on the background, so it is not a flat field.
    image += cv2.GaussianBlur(rng.normal(0, 6, (h, w)), (0, 0), 3)
    side = 120
    margin = side // 4
    tile = np.full((side + 2 * margin, side + 2 * margin), 255, np.uint8)
    placed = []
    for k, (marker_id, quad) in enumerate(markers):
        tile[margin:margin + side, margin:margin + side] = cv2.aruco.generateImageMarker(dictionary, marker_id, side)
        s = float(side)
        src = np.float32([[margin, margin], [margin + s, margin], [margin + s, margin + s], [margin, margin + s]]) - 0.5
        m = cv2.getPerspectiveTransform(src, np.float32(quad))
        # `ink` may be one level or one per marker.
        ink_k = ink[k % len(ink)] if isinstance(ink, (list, tuple)) else ink
        levels = ink_k + (paper - ink_k) * tile.astype(np.float32) / 255.0
        warped = cv2.warpPerspective(levels, m, (w, h), flags=cv2.INTER_AREA, borderValue=-1)
        mask = warped >= 0
        image[mask] = warped[mask]
        placed.append((marker_id, quad))
    light = 1.0 - gradient * np.linspace(0, 1, w)[None, :]
    image = image * light
    image = cv2.GaussianBlur(image, (0, 0), blur)
    image += rng.normal(0, noise, image.shape)
    return np.clip(np.rint(image), 0, 255).astype(np.uint8), placed


def barrel(image, k1):
    """Barrel distortion with radial coefficient k1 (in normalised coordinates, focal length =
    image width, centre in the middle), as cv2.undistort would remove it; returns the image and a
    function that moves a drawn point to where the distortion puts it."""
    h, w = image.shape
    f = float(w)
    cam = np.array([[f, 0, (w - 1) / 2], [0, f, (h - 1) / 2], [0, 0, 1]])
    dist = np.array([k1, 0, 0, 0, 0])
    # For each distorted pixel, where it was in the undistorted picture.
    ys, xs = np.mgrid[0:h, 0:w].astype(np.float32)
    pts = np.stack([xs.ravel(), ys.ravel()], 1).reshape(-1, 1, 2)
    und = cv2.undistortPoints(pts, cam, dist, P=cam).reshape(h, w, 2)
    out = cv2.remap(image.astype(np.float32), und[..., 0], und[..., 1], cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)

    def move(p):
        q = cv2.projectPoints(
            np.array([[[(p[0] - cam[0, 2]) / f, (p[1] - cam[1, 2]) / f, 1.0]]]),
            np.zeros(3), np.zeros(3), cam, dist)[0]
        return q.reshape(2).tolist()

    return np.clip(np.rint(out), 0, 255).astype(np.uint8), move


def detections(image, dictionary, refinement):
    params = cv2.aruco.DetectorParameters()
    if refinement is not None:
        params.cornerRefinementMethod = refinement
    corners, ids, _ = cv2.aruco.ArucoDetector(dictionary, params).detectMarkers(image)
    if ids is None:
        return []
    return sorted(((int(i), c.reshape(-1)) for c, i in zip(corners, ids.flatten())), key=lambda t: t[0])


def write(name, dict_name, image, placed):
    dictionary = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, dict_name))
    OUT.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(OUT / f"{name}.png"), image, [cv2.IMWRITE_PNG_COMPRESSION, 9])
    lines = [f"dict {dict_name}"]
    for marker_id, quad in sorted(placed, key=lambda t: t[0]):
        lines.append(f"placed {marker_id} " + " ".join(f"{v:.3f}" for v in np.float32(quad).reshape(-1)))
    found = {}
    for tag, method in [("opencv", None), ("subpix", cv2.aruco.CORNER_REFINE_SUBPIX), ("contour", cv2.aruco.CORNER_REFINE_CONTOUR)]:
        found[tag] = detections(image, dictionary, method)
        for marker_id, c in found[tag]:
            lines.append(f"{tag} {marker_id} " + " ".join(f"{v:.3f}" for v in c))
    (OUT / f"{name}.txt").write_text("\n".join(lines) + "\n")
    ids = [i for i, _ in found["opencv"]]
    print(f"{name}: placed {len(placed)}, OpenCV finds {len(ids)}: {ids}")


def grid_of_markers(ids, size, cols, side_px, angle_step, squash=1.0, tilt=0.0, jitter=0.0):
    w, h = size
    rows = (len(ids) + cols - 1) // cols
    out = []
    for k, marker_id in enumerate(ids):
        cx = (k % cols + 0.5) * w / cols + rng.uniform(-jitter, jitter)
        cy = (k // cols + 0.5) * h / rows + rng.uniform(-jitter, jitter)
        s = side_px[k % len(side_px)]
        out.append((marker_id, square_quad(cx, cy, s, angle_step * k - 20, squash, tilt)))
    return out


def main():
    d6 = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_6X6_250)
    tag = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_APRILTAG_36h11)
    size = (320, 240)

    # A studio-range camera (luma 16..235): paper at 235, the marker's black at about 55.
    markers = grid_of_markers([3, 17, 42, 99, 150, 211], size, 3, [60, 44, 36], 17, jitter=6)
    image, placed = render(d6, size, markers, paper=235, ink=55, background=150, noise=2.0, blur=0.7)
    write("studio_range", "DICT_6X6_250", image, placed)

    # A dim, low-contrast print: black at 25 % of white, light falling off across the sheet.
    markers = grid_of_markers([5, 23, 64, 128, 200, 249], size, 3, [56, 40, 48], 23, jitter=6)
    image, placed = render(d6, size, markers, paper=120, ink=30, background=80, noise=2.0, blur=0.7, gradient=0.35)
    write("low_contrast", "DICT_6X6_250", image, placed)

    # Grey ink: AprilTag 36h11 printed at 35, 42 and 50 % of the paper's luma (as a laser printer
    # low on toner or a webcam's photo of a tag sheet gives), on a paper-coloured background.
    markers = grid_of_markers([0, 1, 2, 3, 4, 5], size, 3, [64, 48, 40], 11, jitter=5)
    inks = [190 * share for share in (0.35, 0.42, 0.5, 0.5, 0.35, 0.42)]
    image, _ = render(tag, size, markers, paper=190, ink=inks, background=175, noise=2.0, blur=0.8, gradient=0.2)
    write("grey_ink_apriltag", "DICT_APRILTAG_36h11", image, markers)

    # Small and steep: 6x6 markers 20-45 px across, foreshortened 3:1 with perspective, at 640x480
    # (OpenCV's minimum perimeter is a share of the image's size, so the size matters).
    big = (640, 480)
    ids = [1, 7, 30, 55, 81, 102, 133, 177, 190, 222, 240, 248]
    markers = grid_of_markers(ids, (640, 380), 4, [20, 24, 28, 32, 38, 45], 29, jitter=10)
    # Steep ones (3:1, the far edge 15 % shorter) in a band of their own below the upright ones.
    steep = grid_of_markers([11, 44, 66, 88], (640, 100), 4, [45, 50, 55, 60], 13, squash=3.0, tilt=0.15)
    steep = [(i, (np.float32(q) + [0, 380]).tolist()) for i, q in steep]
    image, placed = render(d6, big, markers + steep, paper=215, ink=30, background=120, noise=1.2, blur=0.6)
    write("small_steep", "DICT_6X6_250", image, placed)

    # Barrel distortion, k1 = -0.3: markers near the corners of the frame bend the most.
    markers = grid_of_markers([8, 19, 27, 36, 47, 58, 69, 77, 86], size, 3, [48, 40, 52], 9, jitter=4)
    flat, placed = render(d6, size, markers, paper=220, ink=25, background=110, noise=0.0, blur=0.6)
    image, move = barrel(flat, -0.3)
    image = np.clip(np.rint(image + rng.normal(0, 2.0, image.shape)), 0, 255).astype(np.uint8)
    placed = [(i, [move(p) for p in q]) for i, q in placed]
    write("barrel", "DICT_6X6_250", image, placed)

    if len(sys.argv) > 1:
        # OpenCV's tutorial photos (Apache-2.0 / BSD-3-Clause, see fixtures/recall/LICENSE-photo.txt):
        # six markers on a sheet, and a ChArUco board (markers inside a chessboard's white squares).
        html = pathlib.Path(sys.argv[1]).parent
        for name, file in [("opencv_photo", "singlemarkersoriginal.jpg"), ("opencv_charuco_photo", "choriginal.jpg")]:
            photo = cv2.imread(str(html / file), cv2.IMREAD_GRAYSCALE)
            write(name, "DICT_6X6_250", photo, [])


if __name__ == "__main__":
    main()
