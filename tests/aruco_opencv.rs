//! The detector against OpenCV: marker images generated, warped and detected by OpenCV
//! (`tools/opencv/make_marker_fixtures.py`, committed as data) must give the same ids, with
//! corners in the same order and close to OpenCV's own.

use glint::detect::aruco::{Detector, DetectorConfig, Dictionary};
use glint::frame::{Frame, FrameSize};
use glint::geometry::Point;

const FIXTURES: [(&str, &[u8], &str); 5] = [
    fixture!("dict_4x4_50"),
    fixture!("dict_5x5_100"),
    fixture!("dict_6x6_250"),
    fixture!("dict_7x7_250"),
    fixture!("dict_apriltag_36h11"),
];

macro_rules! fixture {
    ($name:literal) => {
        (
            $name,
            include_bytes!(concat!("../tools/opencv/fixtures/", $name, ".pgm")),
            include_str!(concat!("../tools/opencv/fixtures/", $name, ".txt")),
        )
    };
}
use fixture;

/// Width, height and pixels of a binary PGM as OpenCV writes it (`P5`, maxval 255).
fn parse_pgm(bytes: &[u8]) -> (usize, usize, &[u8]) {
    let text = std::str::from_utf8(&bytes[..20]).unwrap_or_default();
    let header: Vec<&str> = bytes
        .split(|b| b.is_ascii_whitespace())
        .take(4)
        .map(|t| std::str::from_utf8(t).unwrap())
        .collect();
    assert_eq!(header[0], "P5", "{text}");
    let (w, h): (usize, usize) = (header[1].parse().unwrap(), header[2].parse().unwrap());
    (w, h, &bytes[bytes.len() - w * h..])
}

fn to_yuyv(luma: &[u8]) -> Vec<u8> {
    luma.iter().flat_map(|&l| [l, 128]).collect()
}

/// Corners by id from the lines starting with `tag`.
fn corners(text: &str, tag: &str) -> Vec<(u16, [Point; 4])> {
    text.lines()
        .filter_map(|l| l.strip_prefix(tag))
        .map(|l| {
            let v: Vec<f64> = l.split_whitespace().map(|t| t.parse().unwrap()).collect();
            let p = |i: usize| Point::new(v[1 + 2 * i], v[2 + 2 * i]);
            (v[0] as u16, [p(0), p(1), p(2), p(3)])
        })
        .collect()
}

#[test]
fn same_ids_and_corners_as_opencv_in_every_dictionary() {
    for (name, pgm, txt) in FIXTURES {
        let dict: Dictionary = txt
            .lines()
            .next()
            .and_then(|l| l.strip_prefix("dict "))
            .unwrap()
            .parse()
            .unwrap();
        let (w, h, luma) = parse_pgm(pgm);
        let bytes = to_yuyv(luma);
        let size = FrameSize::new(w as u32, h as u32).unwrap();
        let frame = Frame::new_checked(&bytes, size, 2 * w).unwrap();
        let mut detector = Detector::new(size, DetectorConfig::new(dict));
        let mut found = detector.detect(&frame, None).unwrap().to_vec();
        found.sort_by_key(|m| m.id);
        let opencv = corners(txt, "marker ");
        let truth = corners(txt, "truth ");
        let ids: Vec<u16> = found.iter().map(|m| m.id).collect();
        let want: Vec<u16> = opencv.iter().map(|(id, _)| *id).collect();
        assert_eq!(ids, want, "{name}: ids");
        for ((m, (_, cv)), (_, t)) in found.iter().zip(&opencv).zip(&truth) {
            assert!(m.refined, "{name}: id {} not refined", m.id);
            for k in 0..4 {
                let to_opencv = (m.corners[k] - cv[k]).norm();
                let ours = (m.corners[k] - t[k]).norm();
                let theirs = (cv[k] - t[k]).norm();
                eprintln!(
                    "{name} id {} corner {k}: ours {ours:.3} px from truth, OpenCV {theirs:.3}",
                    m.id
                );
                assert!(
                    to_opencv < 0.5,
                    "{name} id {} corner {k}: {to_opencv} px from OpenCV",
                    m.id
                );
                assert!(
                    ours < 0.05,
                    "{name} id {} corner {k}: {ours} px from truth",
                    m.id
                );
            }
        }
    }
}
