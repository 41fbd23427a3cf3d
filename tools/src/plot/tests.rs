use glint::frame::{Frame, FrameSize};
use glint::pipeline::{Pipeline, PipelineConfig};
use glint::sink::{JsonLinesSink, Sink};
use glint::source::FrameMeta;
use glint::track::TrackerConfig;

use super::*;
use crate::scene::Scene;
use crate::stats::Spread;

fn parse(text: &str) -> Result<Track, TrackError> {
    Track::from_jsonl(text.as_bytes())
}

/// The JSON lines `glint track --exposure-us` writes for `frames` frames of a built-in scene.
fn scene_track(name: &str, frames: usize) -> String {
    let mut config = Scene::preset_config(name).unwrap();
    config.frame_count = frames;
    let scene = Scene::new(config).unwrap();
    let size = FrameSize::new(scene.width_px(), scene.height_px()).unwrap();
    let tracker = TrackerConfig {
        exposure_us: Some(scene.exposure_us()),
    };
    let config = PipelineConfig {
        tracker,
        ..PipelineConfig::default()
    };
    let mut pipeline = Pipeline::new(size, config).unwrap();
    let mut buffer = vec![0u8; scene.frame_len_bytes()];
    let mut out = Vec::new();
    {
        let mut sink = JsonLinesSink::new(&mut out, false);
        for index in 0..frames {
            scene.render(index, &mut buffer).unwrap();
            let frame = Frame::new_checked(&buffer, size, size.row_bytes()).unwrap();
            let meta = FrameMeta {
                index: index as u64,
                sequence: index as u64,
                dropped: 0,
                timestamp_us: (index as f64 * 1e6 / scene.fps()).round() as u64,
                monotonic_us: 0,
            };
            sink.write(&pipeline.process(&frame, meta)).unwrap();
        }
        sink.finish().unwrap();
    }
    String::from_utf8(out).unwrap()
}

#[test]
fn speed_from_a_real_track_matches_the_circle_it_was_rendered_from() {
    // circles: r = 20 px at 6 rev/s, 30 fps: consecutive heads are 72° apart on the circle,
    // a chord of 2 r sin 36° = 23.51 px every 1/30 s, 705.3 px/s.
    let track = parse(&scene_track("circles", 30)).unwrap();
    assert_eq!(track.units, Units::Pixels);
    assert_eq!((track.samples.len(), track.found_count()), (30, 30));
    let speeds: Vec<f64> = track.speed_runs().concat().iter().map(|p| p.1).collect();
    assert_eq!(speeds.len(), 29);
    let chord_px_s = 2.0 * 20.0 * 36f64.to_radians().sin() * 30.0;
    let median = Spread::of(&speeds).unwrap().median;
    assert!(
        (median / chord_px_s - 1.0).abs() < 0.02,
        "median speed {median} px/s, expected {chord_px_s}"
    );
}

#[test]
fn floor_coordinates_are_preferred_when_present() {
    let text = concat!(
        r#"{"frame":0,"t":0.0,"found":true,"x":100.0,"y":50.0,"floor_x":10.0,"floor_y":5.0}"#,
        "\n",
        r#"{"frame":1,"t":0.5,"found":true,"x":110.0,"y":50.0,"floor_x":13.0,"floor_y":9.0}"#,
        "\n",
    );
    let track = parse(text).unwrap();
    assert_eq!(track.units, Units::Floor);
    assert_eq!(track.speed_runs(), vec![vec![(0.5, 10.0)]]); // 5 floor units in 0.5 s
    assert_eq!(
        track.length_name(),
        "floor units",
        "no floor_unit in the records"
    );
}

#[test]
fn the_axes_are_labelled_with_the_records_floor_unit() {
    let text = concat!(
        r#"{"t":0.0,"found":true,"x":1.0,"y":1.0,"floor_x":1.0,"floor_y":2.0,"floor_unit":"cm"}"#,
        "\n",
        r#"{"t":0.1,"found":false}"#,
        "\n",
    );
    let track = parse(text).unwrap();
    assert_eq!(track.length_name(), "cm");
    let pixels = parse(r#"{"t":0.0,"found":true,"x":1.0,"y":1.0}"#).unwrap();
    assert_eq!(pixels.length_name(), "px");
}

#[test]
fn mixed_floor_units_are_refused() {
    let text = concat!(
        r#"{"t":0.0,"found":true,"x":1.0,"y":1.0,"floor_x":1.0,"floor_y":2.0,"floor_unit":"cm"}"#,
        "\n",
        r#"{"t":0.1,"found":true,"x":1.0,"y":1.0,"floor_x":10.0,"floor_y":20.0,"floor_unit":"mm"}"#,
        "\n",
    );
    let err = parse(text).unwrap_err();
    assert!(err.to_string().contains("cm and mm"), "{err}");
}

#[test]
fn a_lost_frame_breaks_the_trajectory_and_the_speed() {
    let text = "\
{\"t\":0.0,\"found\":true,\"x\":0.0,\"y\":0.0}
{\"t\":0.1,\"found\":true,\"x\":3.0,\"y\":4.0}
{\"t\":0.2,\"found\":false}

{\"t\":0.3,\"found\":true,\"x\":9.0,\"y\":0.0}
{\"t\":0.4,\"found\":true,\"x\":9.0,\"y\":1.0}
";
    let track = parse(text).unwrap();
    assert_eq!(track.samples.len(), 5, "the blank line is skipped");
    let runs: Vec<_> = track.runs().collect();
    assert_eq!(runs.len(), 2);
    let speeds = track.speed_runs();
    assert_eq!(speeds.len(), 2);
    assert!((speeds[0][0].1 - 50.0).abs() < 1e-9);
    assert!((speeds[1][0].1 - 10.0).abs() < 1e-9);
}

#[test]
fn bad_lines_are_refused_with_their_line_number() {
    let good = r#"{"t":0.0,"found":true,"x":1.0,"y":2.0}"#;
    let cases = [
        ("not json at all", "not a glint track record"),
        (r#"{"found":true,"x":1.0,"y":2.0}"#, "missing field `t`"),
        (r#"{"t":"soon","found":false}"#, "not a glint track record"),
        (r#"[1, 2, 3]"#, "not a glint track record"),
        (r#"{"t":1.0,"found":true,"x":1.0}"#, "x or y is missing"),
        (r#"{"t":-1.0,"found":false}"#, "t goes backwards"),
    ];
    for (line, expected) in cases {
        let text = format!("{good}\n{line}\n");
        let message = parse(&text).unwrap_err().to_string();
        assert!(message.starts_with("line 2: "), "{line}: {message}");
        assert!(message.contains(expected), "{line}: {message}");
    }
}

#[test]
fn empty_input_and_tracks_without_positions_are_refused() {
    assert_eq!(parse(""), Err(TrackError::Empty));
    assert_eq!(parse("\n  \n"), Err(TrackError::Empty));
    let lost = "{\"t\":0.0,\"found\":false}\n{\"t\":0.1,\"found\":false}\n";
    assert_eq!(parse(lost), Err(TrackError::NoPositions { frames: 2 }));
}

/// Bounding box `(x_min, y_min, x_max, y_max)` of the pixels of `colour`.
fn extent_of(canvas: &crate::overlay::Canvas, colour: [u8; 3]) -> Option<(i64, i64, i64, i64)> {
    let mut extent: Option<(i64, i64, i64, i64)> = None;
    for y in 0..canvas.height() as i64 {
        for x in 0..canvas.width() as i64 {
            if canvas.get(x, y) == Some(colour) {
                extent = Some(match extent {
                    None => (x, y, x, y),
                    Some((a, b, c, d)) => (a.min(x), b.min(y), c.max(x), d.max(y)),
                });
            }
        }
    }
    extent
}

#[test]
fn the_trajectory_keeps_circles_round_and_floor_y_points_up() {
    // A wide circle in a tall image: equal scales leave it round anyway.
    let lines: String = (0..=72)
        .map(|k| {
            let a = f64::from(k) * 5f64.to_radians();
            let (x, y) = (100.0 + 40.0 * a.cos(), -20.0 + 40.0 * a.sin());
            format!(
                "{{\"t\":{},\"found\":true,\"x\":{x},\"y\":{y},\"floor_x\":{x},\"floor_y\":{y}}}\n",
                f64::from(k) / 30.0
            )
        })
        .collect();
    let track = parse(&lines).unwrap();
    let canvas = render(&track, 500, 1000, "circle");
    assert_eq!((canvas.width(), canvas.height()), (500, 1000));
    let (x0, y0, x1, y1) = extent_of(&canvas, style::TRAJECTORY).unwrap();
    let (w, h) = (x1 - x0, y1 - y0);
    assert!(w > 100, "the circle is drawn large: {w} px");
    assert!((w - h).abs() <= 2, "a circle {w} px wide and {h} px high");
    assert!(
        extent_of(&canvas, style::SPEED).is_some(),
        "the speed curve is drawn"
    );

    // Floor y grows upwards: a track going to +y ends above where it started.
    let up = "{\"t\":0.0,\"found\":true,\"x\":0,\"y\":0,\"floor_x\":0.0,\"floor_y\":0.0}\n\
              {\"t\":0.1,\"found\":true,\"x\":0,\"y\":0,\"floor_x\":0.0,\"floor_y\":50.0}\n";
    let canvas = render(&parse(up).unwrap(), 400, 400, "up");
    let start = extent_of(&canvas, style::START).unwrap();
    let end = extent_of(&canvas, style::END).unwrap();
    assert!(end.3 < start.1, "end {end:?} is above start {start:?}");
}

#[test]
fn a_single_position_still_renders_at_the_requested_size() {
    let track = parse("{\"t\":0.0,\"found\":true,\"x\":5.0,\"y\":5.0}\n").unwrap();
    let canvas = render(&track, 300, 260, "one point");
    assert_eq!((canvas.width(), canvas.height()), (300, 260));
    assert!(extent_of(&canvas, style::START).is_some());
    // Sizes beyond the limits are clamped, never allocated as asked.
    let canvas = render(&track, 1, usize::MAX, "clamped");
    assert_eq!(
        (canvas.width(), canvas.height()),
        (MIN_SIDE_PX, MAX_SIDE_PX)
    );
}
