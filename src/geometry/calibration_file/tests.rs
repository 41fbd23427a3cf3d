//! The calibration file's checks, version 1 and 2.

use super::*;

const SIZE: (u32, u32) = (640, 480);

/// An oblique view of the floor, cm → px.
fn floor_to_screen() -> Matrix3<f64> {
    Matrix3::new(2.1, 0.3, 320.0, -0.2, 1.4, 240.0, 0.0004, 0.0021, 1.0)
}

fn rows(m: &Matrix3<f64>) -> String {
    (0..3)
        .map(|r| format!("[{:?}, {:?}, {:?}]", m[(r, 0)], m[(r, 1)], m[(r, 2)]))
        .collect::<Vec<_>>()
        .join(", ")
}

/// A correct file for a 20 cm marker at the floor origin, as `glint calibrate` lays it out.
fn good_file() -> String {
    let h = Homography::from_matrix(floor_to_screen()).unwrap();
    let inv = h.inverse().unwrap();
    let placement = MarkerPlacement {
        id: 23,
        size: 20.0,
        origin: Point::new(0.0, 0.0),
    };
    let corners: Vec<String> = placement
        .corners()
        .iter()
        .map(|c| {
            let p = h.apply(c).unwrap();
            format!("[{:?}, {:?}]", p.x, p.y)
        })
        .collect();
    format!(
        "# a comment\nwidth_px = {}\nheight_px = {}\nunits = \"cm\"\n\
         dictionary = \"DICT_6X6_250\"\nframes = 1\n\n[homography]\n\
         floor_to_screen = [{}]\nscreen_to_floor = [{}]\n\n[[marker]]\nid = 23\n\
         size_cm = 20.0\norigin_cm = [0.0, 0.0]\ncorners_px = [{}]\n\
         residuals_px = [0.0, 0.0, 0.0, 0.0]\n",
        SIZE.0,
        SIZE.1,
        rows(h.matrix()),
        rows(inv.matrix()),
        corners.join(", ")
    )
}

#[test]
fn the_markers_corners_come_back_for_drawing() {
    let text = good_file();
    assert!(parse(&text).is_ok());
    let markers = CalibrationFile::marker_corners_px(&text).unwrap();
    assert_eq!(markers.len(), 1);
    // The first corner is the marker's floor origin seen through the matrix.
    let h = Homography::from_matrix(floor_to_screen()).unwrap();
    let p = h.apply(&Point::new(0.0, 0.0)).unwrap();
    let (x, y) = markers[0][0];
    assert!((f64::from(x) - p.x).abs() < 1e-3 && (f64::from(y) - p.y).abs() < 1e-3);
    assert!(CalibrationFile::marker_corners_px("not toml [").is_err());
}

fn frames() -> FrameSize {
    FrameSize::new(SIZE.0, SIZE.1).unwrap()
}

fn parse(text: &str) -> Result<CalibrationFile, CalibrationFileError> {
    CalibrationFile::parse(text, frames())
}

#[test]
fn a_correct_file_maps_like_its_matrix() {
    let c = parse(&good_file()).unwrap();
    assert_eq!(c.size, frames());
    assert_eq!(c.dictionary, Some(Dictionary::Aruco6x6_250));
    assert_eq!(c.floor.unit(), FloorUnit::Cm);
    let truth = Homography::from_matrix(floor_to_screen()).unwrap();
    let floor = Point::new(35.0, -12.0);
    let screen = truth.apply(&floor).unwrap();
    let back = c.floor.mapping().unwrap().screen_to_floor(&screen).unwrap();
    assert!((back - floor).norm() < 1e-9, "{back:?}");
}

#[test]
fn missing_fields_are_named() {
    let good = good_file();
    for (line_start, field) in [
        ("width_px", "width_px"),
        ("units", "units"),
        ("screen_to_floor", "screen_to_floor"),
        ("residuals_px", "residuals_px"),
    ] {
        let text: String = good
            .lines()
            .filter(|l| !l.starts_with(line_start))
            .map(|l| format!("{l}\n"))
            .collect();
        let err = parse(&text).unwrap_err();
        assert!(
            err.to_string()
                .contains(&format!("missing field `{field}`")),
            "{field}: {err}"
        );
    }
    let no_markers: String = good.split("[[marker]]").next().unwrap().to_owned();
    assert_eq!(
        parse(&no_markers).unwrap_err(),
        CalibrationFileError::NoMarkers
    );
}

#[test]
fn syntax_errors_carry_their_line() {
    let text = good_file().replacen("units = \"cm\"", "units = cm", 1);
    let err = parse(&text).unwrap_err();
    assert!(
        matches!(err, CalibrationFileError::Syntax { line: Some(4), .. }),
        "{err:?}"
    );
    let err = parse(&good_file().replacen("[0.0, 0.0, 0.0, 0.0]", "[0.0, 0.0]", 1)).unwrap_err();
    assert!(err.to_string().contains("residuals_px"), "{err}");
}

#[test]
fn another_frame_size_is_refused() {
    let err = CalibrationFile::parse(&good_file(), FrameSize::new(320, 240).unwrap());
    assert_eq!(
        err.unwrap_err().to_string(),
        "made for 640x480 frames, but the frames are 320x240; calibrate again at 320x240"
    );
    let odd = good_file().replacen("width_px = 640", "width_px = 641", 1);
    assert!(matches!(
        parse(&odd),
        Err(CalibrationFileError::BadFrameSize(SizeError::OddWidth(641)))
    ));
}

#[test]
fn bad_numbers_and_degenerate_matrices_are_refused() {
    let good = good_file();
    let h = Homography::from_matrix(floor_to_screen()).unwrap();
    let f2s = format!("floor_to_screen = [{}]", rows(h.matrix()));
    let s2f = format!(
        "screen_to_floor = [{}]",
        rows(h.inverse().unwrap().matrix())
    );
    // NaN is valid TOML.
    let nan = good.replacen(
        &f2s,
        "floor_to_screen = [[nan, 0.3, 320.0], [-0.2, 1.4, 240.0], [0.0004, 0.0021, 1.0]]",
        1,
    );
    assert_eq!(
        parse(&nan).unwrap_err(),
        CalibrationFileError::NonFinite(MatrixName::FloorToScreen)
    );
    let singular = good.replacen(
        &s2f,
        "screen_to_floor = [[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 0.0, 1.0]]",
        1,
    );
    assert_eq!(
        parse(&singular).unwrap_err(),
        CalibrationFileError::Degenerate(MatrixName::ScreenToFloor, HomographyError::Singular)
    );
    // A plausible matrix that is not the other's inverse (one digit changed).
    let edited = good.replacen("[2.1, 0.3, 320.0]", "[2.1, 0.3, 321.0]", 1);
    assert_eq!(
        parse(&edited).unwrap_err(),
        CalibrationFileError::MatricesDisagree
    );
    let units = good.replacen("units = \"cm\"", "units = \"furlongs\"", 1);
    assert!(parse(&units).unwrap_err().to_string().contains("furlongs"));
    let size = good.replacen("size_cm = 20.0", "size_cm = -20.0", 1);
    assert_eq!(
        parse(&size).unwrap_err(),
        CalibrationFileError::BadMarker { id: 23 }
    );
}

#[test]
fn corners_that_disagree_with_the_matrix_are_refused() {
    // The marker said to be 25 cm: its corners are no longer where the matrix puts them.
    let text = good_file().replacen("size_cm = 20.0", "size_cm = 25.0", 1);
    let err = parse(&text).unwrap_err();
    assert!(
        matches!(
            err,
            CalibrationFileError::ResidualMismatch {
                id: 23,
                corner: 1,
                ..
            }
        ),
        "{err:?}"
    );
    let text = good_file().replacen("corners_px = [[", "corners_px = [[-5", 1);
    assert!(matches!(
        parse(&text),
        Err(CalibrationFileError::CornerOutsideFrame { id: 23, corner: 0 })
    ));
}

/// A version-2 file, as `glint calibrate` writes it: the wide lens over two markers.
fn good_v2() -> (String, CameraModel) {
    use crate::geometry::calibration_record::{CalibrationRecord, RecordedMarker};
    let centre = Vector3::new(10.0, -70.0, -130.0);
    let forward = Vector3::new(0.0, 1.1f64.cos(), 1.1f64.sin());
    let camera = CameraModel {
        lens: Lens {
            k1: -0.3,
            k2: 0.09,
            p1: 0.001,
            ..Lens::ideal(460.0, 460.0, 319.5, 239.5)
        },
        pose: Pose::looking_at(centre, centre + forward).unwrap(),
    };
    let markers = [(23, 0.0, 0.0), (7, 40.0, 30.0)].map(|(id, x, y)| {
        let placement = MarkerPlacement {
            id,
            size: 20.0,
            origin: Point::new(x, y),
        };
        RecordedMarker {
            placement,
            frames_seen: 3,
            // A little off where the camera puts them: residuals that are not zero.
            corners_px: placement
                .corners()
                .map(|c| camera.project(&c, 0.0).unwrap() + nalgebra::Vector2::new(0.03, -0.02)),
        }
    });
    let record = CalibrationRecord {
        size: frames(),
        dictionary: Dictionary::Aruco6x6_250,
        frames: 3,
        lens_source: "fitted".to_owned(),
        camera,
        markers: markers.to_vec(),
        unseen: vec![5],
    };
    (record.to_toml().unwrap(), camera)
}

fn without(text: &str, line_start: &str) -> String {
    text.lines()
        .filter(|l| !l.starts_with(line_start))
        .map(|l| format!("{l}\n"))
        .collect()
}

#[test]
fn a_version_2_file_maps_through_its_lens_and_pose() {
    let (text, camera) = good_v2();
    let c = parse(&text).unwrap();
    assert_eq!(c.version, 2);
    assert_eq!(c.floor.camera(), Some(&camera));
    let floor = Point::new(35.0, -12.0);
    let screen = camera.project(&floor, 0.0).unwrap();
    let back = c.floor.screen_to_floor(&screen).unwrap();
    assert!((back - floor).norm() < 1e-9, "{back:?}");
    assert!(
        (c.max_residual_px - 0.036).abs() < 1e-3,
        "{}",
        c.max_residual_px
    );
}

#[test]
fn a_version_2_file_needs_every_field() {
    let (text, _) = good_v2();
    for (line_start, needle) in [
        ("frames =", "missing field `frames`"),
        ("unseen", "missing field `unseen`"),
        ("k1", "missing field `k1`"),
        ("height_cm", "missing field `height_cm`"),
        ("rms_px", "missing field `rms_px`"),
        ("max_px", "missing field `max_px`"),
        ("corners =", "missing field `corners`"),
        ("residuals_px", "missing field `residuals_px`"),
    ] {
        let err = parse(&without(&text, line_start)).unwrap_err();
        assert!(err.to_string().contains(needle), "{line_start}: {err}");
    }
    let no_section = |name: &str| {
        let start = text.find(&format!("[{name}]")).unwrap();
        let end = text[start + 1..]
            .find("\n[")
            .map_or(text.len(), |e| start + 1 + e);
        format!("{}{}", &text[..start], &text[end..])
    };
    for name in ["lens", "pose", "residuals"] {
        assert_eq!(
            parse(&no_section(name)).unwrap_err(),
            CalibrationFileError::Missing(match name {
                "lens" => "lens",
                "pose" => "pose",
                _ => "residuals",
            }),
            "{name}"
        );
    }
    let typo = text.replacen("k2 =", "k_2 =", 1);
    assert!(parse(&typo).unwrap_err().to_string().contains("k_2"));
}

#[test]
fn edited_numbers_in_a_version_2_file_are_refused() {
    let (text, camera) = good_v2();
    let field = |key: &str| {
        text.lines()
            .find(|l| l.starts_with(key))
            .unwrap()
            .to_owned()
    };
    let k1 = field("k1 =");
    let err = parse(&text.replacen(&k1, "k1 = -0.31", 1)).unwrap_err();
    assert!(
        matches!(err, CalibrationFileError::ResidualMismatch { .. }),
        "{err}"
    );
    assert_eq!(
        parse(&text.replacen(&k1, "k1 = nan", 1)).unwrap_err(),
        CalibrationFileError::Lens(CameraError::NonFinite)
    );
    assert_eq!(
        parse(&text.replacen(&k1, "k1 = -3000.0", 1)).unwrap_err(),
        CalibrationFileError::Lens(CameraError::AbsurdCoefficient)
    );
    let height = field("height_cm");
    let err = parse(&text.replacen(&height, "height_cm = 150.0", 1)).unwrap_err();
    assert!(
        matches!(err, CalibrationFileError::HeightMismatch { .. }),
        "{err}"
    );
    assert!((camera.pose.height() - 130.0).abs() < 1e-9);
    let rms = field("rms_px");
    let err = parse(&text.replacen(&rms, "rms_px = 0.5", 1)).unwrap_err();
    assert!(err.to_string().contains("[residuals] rms_px"), "{err}");
    let corners = field("corners =");
    let err = parse(&text.replacen(&corners, "corners = 12", 1)).unwrap_err();
    assert!(err.to_string().contains("[residuals] corners"), "{err}");
    let err = parse(&text.replacen("frames_seen = 3", "frames_seen = 9", 1)).unwrap_err();
    assert!(
        matches!(err, CalibrationFileError::FramesSeen { id: 23, .. }),
        "{err}"
    );
    let rotation = field("rotation");
    let scaled = rotation.replacen("[-1.0,", "[-1.1,", 1);
    assert_ne!(scaled, rotation);
    assert_eq!(
        parse(&text.replacen(&rotation, &scaled, 1)).unwrap_err(),
        CalibrationFileError::Pose(CameraError::NotARotation)
    );
}

#[test]
fn units_must_agree_with_the_files_numbers() {
    // Relabelling cm as mm would scale every position silently by ten.
    let (v2, _) = good_v2();
    for text in [good_file(), v2] {
        for units in ["mm", "m", "in"] {
            let edited = text.replacen("units = \"cm\"", &format!("units = \"{units}\""), 1);
            let err = parse(&edited).unwrap_err();
            assert!(
                matches!(err, CalibrationFileError::UnitsDisagree(_)),
                "{err}"
            );
            assert!(err.to_string().contains("must be \"cm\""), "{err}");
        }
    }
}

#[test]
fn versions_this_glint_does_not_know_are_refused() {
    let (text, _) = good_v2();
    for v in [0, 3, -1] {
        let edited = text.replacen("version = 2", &format!("version = {v}"), 1);
        assert_eq!(
            parse(&edited).unwrap_err(),
            CalibrationFileError::Version(v)
        );
    }
    // A version-1 file may say so.
    assert!(parse(&format!("version = 1\n{}", good_file())).is_ok());
}

#[test]
fn a_version_1_residuals_section_is_optional_but_checked() {
    let good = good_file();
    let with = format!(
        "{}\n[residuals]\ncorners = 4\nrms_px = 0.0\nmax_px = 0.0\n",
        good.split("[[marker]]").next().unwrap()
    ) + "[[marker]]"
        + good.split("[[marker]]").nth(1).unwrap();
    assert!(parse(&with).is_ok(), "{:?}", parse(&with));
    let wrong = with.replacen("corners = 4", "corners = 8", 1);
    assert!(parse(&wrong)
        .unwrap_err()
        .to_string()
        .contains("[residuals] corners"));
    let wrong = with.replacen("max_px = 0.0", "max_px = 0.2", 1);
    assert!(parse(&wrong)
        .unwrap_err()
        .to_string()
        .contains("[residuals] max_px"));
    // Without the section (and without `frames`), the file of an older glint still loads.
    assert_eq!(parse(&without(&good, "frames")).unwrap().version, 1);
}
