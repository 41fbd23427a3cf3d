//! The fuser on hand-written report lines: several robots, the weights near a picture's edge,
//! a sighting moved on by its age, and the reports it refuses.

use super::line::parse;
use super::*;

fn fuser(cameras: usize, robots: u32) -> Fuser {
    Fuser::new(
        cameras,
        FuseConfig {
            robots,
            picture_px: Some((640, 480)),
        },
    )
}

/// Pushes `(camera, line)` in order and returns every step written, the end included.
fn run(f: &mut Fuser, lines: &[(usize, &str)]) -> Vec<FusedStep> {
    let mut steps = Vec::new();
    for (camera, line) in lines {
        let report = parse(line, None).unwrap();
        f.push(*camera, &report, &mut |s| steps.push(s.clone()))
            .unwrap();
    }
    f.finish(&mut |s| steps.push(s.clone()));
    steps
}

/// A found single-LED line at `t` s: floor `(fx, fy)` cm seen at picture x `px`.
fn seen(t: f64, px: f64, fx: f64, fy: f64) -> String {
    format!(
        r#"{{"t":{t},"found":true,"x":{px},"y":240,"mid_x":{px},"mid_y":240,"pos_method":"head","floor_x":{fx},"floor_y":{fy},"floor_unit":"cm","area_px":50,"len_px":0}}"#
    )
}

#[test]
fn several_robots_lines_give_one_track_per_id() {
    let mut f = fuser(2, 2);
    let a = r#"{"t":1.0,"tracks":[{"id":1,"found":true,"x":100,"y":100,"floor_x":10,"floor_y":20,"floor_unit":"cm"},{"id":3,"found":true,"x":5,"y":5,"floor_x":1,"floor_y":1,"floor_unit":"cm"}]}"#;
    let b = r#"{"t":1.0,"tracks":[{"id":2,"found":true,"x":200,"y":100,"floor_x":50,"floor_y":60,"floor_unit":"cm"},{"id":1,"found":false}]}"#;
    let steps = run(&mut f, &[(0, a), (1, b)]);
    let [step] = steps.as_slice() else {
        panic!("{steps:?}")
    };
    assert_eq!(step.t_us, 1_000_000);
    let [one, two] = step.tracks.as_slice() else {
        panic!()
    };
    assert_eq!((one.id, one.floor), (1, Some(Point::new(10.0, 20.0))));
    assert_eq!(one.cameras, [(0, 1.0)]);
    assert_eq!((two.id, two.floor), (2, Some(Point::new(50.0, 60.0))));
    assert_eq!(two.cameras, [(1, 1.0)]);
    assert_eq!(f.counts().other_ids, 1, "id 3 is beyond --robots 2");
}

#[test]
fn a_spot_cut_by_the_edge_gives_way_to_the_other_camera() {
    // Camera a sees the 4 px spot 3 px from its right edge, b well inside its picture.
    let mut f = fuser(2, 1);
    let steps = run(
        &mut f,
        &[
            (0, &seen(1.0, 636.0, 10.6, 5.0)),
            (1, &seen(1.0, 300.0, 10.0, 5.0)),
        ],
    );
    let track = &steps[0].tracks[0];
    assert_eq!(track.floor, Some(Point::new(10.0, 5.0)));
    assert_eq!(track.cameras, [(1, 1.0)]);
    // Both well inside: equal uncertainties, equal weights.
    let mut f = fuser(2, 1);
    let steps = run(
        &mut f,
        &[
            (0, &seen(1.0, 500.0, 10.6, 5.0)),
            (1, &seen(1.0, 300.0, 10.0, 5.0)),
        ],
    );
    let track = &steps[0].tracks[0];
    assert!((track.floor.unwrap().x - 10.3).abs() < 1e-9, "{track:?}");
    assert_eq!(track.cameras, [(0, 0.5), (1, 0.5)]);
}

#[test]
fn a_camera_between_its_frames_is_moved_on_by_its_velocity() {
    // Camera a reports every 20 ms at 100 cm/s; b reports 10 ms after a's frames.
    let moving_at = |t: f64, x: f64, vx: f64| {
        format!(
            r#"{{"t":{t},"found":true,"x":300,"y":240,"floor_x":{x},"floor_y":0,"floor_unit":"cm","floor_vx":{vx},"floor_vy":0,"area_px":50,"len_px":0}}"#
        )
    };
    let moving = |t: f64, x: f64| moving_at(t, x, 100.0);
    let mut f = fuser(2, 1);
    let steps = run(
        &mut f,
        &[
            (0, &moving(0.00, 0.0)),
            (0, &moving(0.02, 2.0)),
            (1, &seen(0.03, 300.0, 3.0, 0.0)),
        ],
    );
    let last = steps.last().unwrap();
    assert_eq!(last.t_us, 30_000);
    let track = &last.tracks[0];
    // a, 10 ms old, is moved on 1 cm: both say 3.0.
    assert!((track.floor.unwrap().x - 3.0).abs() < 1e-9, "{track:?}");
    // Half a frame old, a counts 1 / (1 + 0.5²) of b.
    let (wa, wb) = (track.cameras[0].1, track.cameras[1].1);
    assert!((wa / wb - 0.8).abs() < 1e-9, "{track:?}");
    // A reported velocity far off (a short streak read as a long one) does not throw the
    // sighting: it is moved on by its travel over the last frame.
    let mut f = fuser(2, 1);
    let steps = run(
        &mut f,
        &[
            (0, &moving(0.00, 0.0)),
            (0, &moving_at(0.02, 2.0, 500.0)),
            (1, &seen(0.03, 300.0, 3.0, 0.0)),
        ],
    );
    let track = &steps.last().unwrap().tracks[0];
    assert!((track.floor.unwrap().x - 3.0).abs() < 1e-9, "{track:?}");
    // A sighting older than one and a half frames no longer counts.
    let mut f = fuser(2, 1);
    let steps = run(
        &mut f,
        &[
            (0, &moving(0.00, 0.0)),
            (0, &moving(0.02, 2.0)),
            (1, &seen(0.051, 300.0, 5.1, 0.0)),
        ],
    );
    assert_eq!(steps.last().unwrap().tracks[0].cameras, [(1, 1.0)]);
}

#[test]
fn reports_out_of_order_or_in_another_unit_are_refused() {
    let mut f = fuser(2, 1);
    let mut sink = |_: &FusedStep| {};
    let r = |line: &str| parse(line, None).unwrap();
    f.push(0, &r(&seen(1.0, 300.0, 1.0, 1.0)), &mut sink)
        .unwrap();
    assert!(matches!(
        f.push(0, &r(&seen(0.5, 300.0, 1.0, 1.0)), &mut sink),
        Err(PushError::BackInTime { .. })
    ));
    f.push(1, &r(&seen(1.5, 300.0, 1.0, 1.0)), &mut sink)
        .unwrap();
    f.push(0, &r(&seen(2.0, 300.0, 1.0, 1.0)), &mut sink)
        .unwrap();
    // b's report at 1.2 s comes after the step at 1.5 s was written.
    assert!(matches!(
        f.push(1, &r(&seen(1.2, 300.0, 1.0, 1.0)), &mut sink),
        Err(PushError::BackInTime { .. })
    ));
    let mut g = fuser(2, 1);
    g.push(0, &r(&seen(1.0, 300.0, 1.0, 1.0)), &mut sink)
        .unwrap();
    g.push(0, &r(&seen(2.0, 300.0, 1.0, 1.0)), &mut sink)
        .unwrap();
    // b's first report, at 0.9 s, comes after the step at 1.0 s was written.
    assert!(matches!(
        g.push(1, &r(&seen(0.9, 300.0, 1.0, 1.0)), &mut sink),
        Err(PushError::Late { .. })
    ));
    let mm = seen(3.0, 300.0, 10.0, 10.0).replace("\"cm\"", "\"mm\"");
    let e = g.push(1, &r(&mm), &mut sink).unwrap_err();
    assert!(e.to_string().contains("floor numbers in mm"), "{e}");
    assert_eq!(g.counts().other_units, 1);
    assert!(matches!(
        g.push(7, &r(&seen(4.0, 1.0, 1.0, 1.0)), &mut sink),
        Err(PushError::UnknownCamera(7))
    ));
}

#[test]
fn a_message_is_parsed_with_the_transports_capture_time() {
    let mut f = fuser(1, 1);
    let mut steps = Vec::new();
    let line = seen(99.0, 300.0, 1.0, 2.0);
    f.push_line(0, Some(5_000), &line, &mut |s| steps.push(s.clone()))
        .unwrap();
    let e = f.push_line(0, None, "{\"t\":1,", &mut |_| {}).unwrap_err();
    assert!(matches!(e, MessageError::Line(_)), "{e}");
    let e = f.push_line(0, Some(4_000), &line, &mut |_| {}).unwrap_err();
    assert!(
        matches!(e, MessageError::Push(PushError::BackInTime { .. })),
        "{e}"
    );
    f.finish(&mut |s| steps.push(s.clone()));
    assert_eq!(steps.len(), 1);
    assert_eq!(
        steps[0].t_us, 5_000,
        "the transport's time, not the line's 99 s"
    );
}

/// A found line at 1 s seen at `(px, 240)` moving 100 px/s, 50 cm/s on the floor (0.5 cm a
/// pixel), with a calibration residual of `residual_px`.
fn moving(px: f64, floor_x: f64, residual_px: f64, with_velocity: bool) -> String {
    let velocity = if with_velocity {
        r#","vx":100,"vy":0,"floor_vx":50,"floor_vy":0"#
    } else {
        ""
    };
    format!(
        r#"{{"t":1.0,"found":true,"x":{px},"y":240,"mid_x":{px},"mid_y":240,"pos_method":"head","floor_x":{floor_x},"floor_y":5,"floor_unit":"cm","area_px":50,"len_px":0,"calib":{{"residual_px":{residual_px}}}{velocity}}}"#
    )
}

#[test]
fn the_fused_sigma_is_the_inverse_variance_combination() {
    // a: σ² = (1 + 1/12) px² × 0.25 cm²/px²; b: σ² = 1/12 px² × 0.25. Inverse-variance
    // weights (both far from the edges) give the fused variance 1 / (1/σa² + 1/σb²).
    let mut f = fuser(2, 1);
    let steps = run(
        &mut f,
        &[
            (0, &moving(300.0, 10.0, 1.0, true)),
            (1, &moving(320.0, 10.2, 0.0, true)),
        ],
    );
    let track = &steps[0].tracks[0];
    let (va, vb): (f64, f64) = ((1.0 + 1.0 / 12.0) * 0.25, (1.0 / 12.0) * 0.25);
    let expected = (1.0 / (1.0 / va + 1.0 / vb)).sqrt();
    let sigma = track.sigma.expect("both cameras know their floor scale");
    assert!((sigma - expected).abs() < 1e-9, "{sigma} vs {expected}");
    // One camera alone: its own σ.
    let mut f = fuser(1, 1);
    let steps = run(&mut f, &[(0, &moving(300.0, 10.0, 1.0, true))]);
    let sigma = steps[0].tracks[0].sigma.unwrap();
    assert!((sigma - va.sqrt()).abs() < 1e-9, "{sigma}");
    // A camera that has not measured its floor scale: no σ in floor units.
    let mut f = fuser(2, 1);
    let steps = run(
        &mut f,
        &[
            (0, &moving(300.0, 10.0, 1.0, true)),
            (1, &moving(320.0, 10.2, 0.0, false)),
        ],
    );
    assert_eq!(steps[0].tracks[0].sigma, None);
}
