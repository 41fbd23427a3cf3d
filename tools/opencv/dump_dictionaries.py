#!/usr/bin/env python3
"""Dump OpenCV's predefined ArUco / AprilTag dictionaries as Rust data for glint.

Usage: pip install opencv-contrib-python-headless; python3 tools/opencv/dump_dictionaries.py

Writes src/detect/aruco/dict/<name>.rs. Each code is the marker's inner bit grid as printed
(rotation 0), read row by row from the top-left cell, most significant bit first; a set bit is a
white cell. This is the layout of OpenCV's `getBitsFromByteList(bytesList[id], markerSize)`.
The output is committed, so building and testing glint never needs Python or OpenCV.
"""
import pathlib

import cv2

DICTIONARIES = [
    "DICT_4X4_50",
    "DICT_5X5_100",
    "DICT_6X6_250",
    "DICT_7X7_250",
    "DICT_APRILTAG_36h11",
]

OUT_DIR = pathlib.Path(__file__).resolve().parents[2] / "src" / "geometry" / "aruco" / "dict"


def codes(dictionary):
    n = dictionary.markerSize
    out = []
    for marker_id in range(dictionary.bytesList.shape[0]):
        bits = cv2.aruco.Dictionary.getBitsFromByteList(
            dictionary.bytesList[marker_id : marker_id + 1], n
        )
        value = 0
        for bit in bits.flatten():
            value = (value << 1) | int(bit)
        out.append(value)
    return out


def main():
    OUT_DIR.mkdir(parents=True, exist_ok=True)
    for name in DICTIONARIES:
        d = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, name))
        values = codes(d)
        lines = [
            f"// {name}, dumped from OpenCV {cv2.__version__} by tools/opencv/dump_dictionaries.py.",
            "// Do not edit: regenerate instead.",
            f"pub(super) const MARKER_BITS: usize = {d.markerSize};",
            f"pub(super) const MAX_CORRECTION_BITS: u32 = {d.maxCorrectionBits};",
            f"pub(super) const CODES: [u64; {len(values)}] = [",
        ]
        lines += [f"    0x{v:016x}," for v in values]
        lines.append("];")
        path = OUT_DIR / f"{name.lower()}.rs"
        path.write_text("\n".join(lines) + "\n")
        print(f"{path}: {len(values)} codes of {d.markerSize}x{d.markerSize} bits")


if __name__ == "__main__":
    main()
