//! The rig's camera: the scene renderer (`crate::scene`) looking at the floor the robot drives
//! on, from about 1.5 m, with four ArUco markers around the figure-eight for glint's floor
//! calibration. Each frame is rendered from the robot's actual positions at the start and the
//! end of that frame's exposure (a straight streak between them: over a 4 ms exposure the
//! robot's arc departs from its chord by micrometres).

use glint::detect::aruco::Dictionary;
use glint::geometry::Point as FloorPoint;

use crate::markers::{Camera as MarkerCamera, PlacedMarker};
use crate::scene::{Lens, Point, Scene, SceneConfig, SceneError, Trajectory, View};

/// Frame size, rate and exposure of the rig's camera.
pub const WIDTH_PX: u32 = 640;
pub const HEIGHT_PX: u32 = 480;
pub const FPS: f64 = 30.0;
pub const EXPOSURE_US: u32 = 4_000;
/// Frames a rig may render (half an hour at 30 fps): bounds the scene's frame numbers.
const MAX_FRAMES: usize = 54_000;
/// Side of the calibration markers, cm.
const MARKER_CM: f64 = 16.0;
/// Top-left corners of the markers (cm): two beyond each end of the figure-eight, near the
/// picture's corners.
const MARKER_ORIGINS_CM: [(f64, f64); 4] =
    [(-80.0, -52.0), (-96.0, 30.0), (64.0, -52.0), (80.0, 30.0)];
/// Their ids (DICT_6X6_250).
const MARKER_IDS: [u16; 4] = [11, 12, 13, 14];
/// Centimetres per metre.
const CM_PER_M: f64 = 100.0;
/// The preset the LED, floor and sensor noise are taken from.
const LOOKS_LIKE: &str = "figure-eight";

/// The camera: 1.3 m up and 0.7 m back from the figure's centre, looking at it (1.48 m away),
/// 640×480 and about 70° wide.
pub fn rig_camera() -> MarkerCamera {
    MarkerCamera {
        width_px: WIDTH_PX as usize,
        height_px: HEIGHT_PX as usize,
        focal_px: 460.0,
        position_cm: [0.0, -70.0, 130.0],
        look_at_cm: [0.0, 0.0, 0.0],
    }
}

/// The calibration markers on the floor.
pub fn rig_markers() -> Vec<PlacedMarker> {
    MARKER_IDS
        .iter()
        .zip(MARKER_ORIGINS_CM)
        .map(|(&id, (x, y))| PlacedMarker {
            dictionary: Dictionary::Aruco6x6_250,
            id,
            size_cm: MARKER_CM,
            origin_cm: FloorPoint::new(x, y),
            rotation_deg: 0.0,
        })
        .collect()
}

/// Why a frame could not be rendered.
#[derive(Debug, Clone, PartialEq)]
pub enum CameraError {
    /// The scene renderer refused.
    Scene(SceneError),
    /// A floor point is not in front of the camera.
    BehindCamera,
    /// More frames than the rig allows.
    TooManyFrames,
}

impl std::fmt::Display for CameraError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CameraError::Scene(e) => write!(f, "{e}"),
            CameraError::BehindCamera => write!(f, "the robot is not in front of the camera"),
            CameraError::TooManyFrames => {
                write!(f, "the rig renders at most {MAX_FRAMES} frames")
            }
        }
    }
}

impl std::error::Error for CameraError {}

/// The rig's camera and its scene.
pub struct RigCamera {
    scene: Scene,
    camera: MarkerCamera,
}

impl RigCamera {
    /// The camera with sensor noise from `seed`.
    pub fn new(seed: u64) -> Result<Self, CameraError> {
        let mut config: SceneConfig =
            Scene::preset_config(LOOKS_LIKE).ok_or(CameraError::Scene(SceneError::Invalid {
                field: "name",
                reason: "the rig's look-alike preset is missing",
            }))?;
        let camera = rig_camera();
        config.name = "rig".to_owned();
        config.summary = "the robot-in-the-loop rig's camera".to_owned();
        config.exposure_us = EXPOSURE_US;
        config.fps = FPS;
        config.frame_count = MAX_FRAMES;
        config.seed = seed;
        config.view = Some(View {
            camera,
            lens: Lens::ideal(&camera),
            led_height_cm: 0.0,
            knock: None,
            bump: None,
            markers: rig_markers(),
        });
        let scene = Scene::new(config).map_err(CameraError::Scene)?;
        Ok(RigCamera { scene, camera })
    }

    /// Bytes in one YUYV frame.
    pub fn frame_len_bytes(&self) -> usize {
        self.scene.frame_len_bytes()
    }

    /// The `--marker` arguments of `glint calibrate` for the markers in view.
    pub fn marker_args(&self) -> Vec<String> {
        self.scene
            .config()
            .view
            .as_ref()
            .map(View::marker_args)
            .unwrap_or_default()
    }

    /// The reference pixel where a floor point (m) is seen.
    fn pixel_of(&self, floor_m: (f64, f64)) -> Result<Point, CameraError> {
        let p = self
            .camera
            .project(FloorPoint::new(floor_m.0 * CM_PER_M, floor_m.1 * CM_PER_M))
            .ok_or(CameraError::BehindCamera)?;
        Ok(Point::new(p.x, p.y))
    }

    /// Renders frame `frame` (its exposure ends at `frame / FPS` of scene time) into `out`:
    /// the LED moving from `start_m` at the exposure's start to `end_m` at its end, or no
    /// LED when `lit` is false.
    pub fn render(
        &mut self,
        frame: usize,
        start_m: (f64, f64),
        end_m: (f64, f64),
        lit: bool,
        out: &mut [u8],
    ) -> Result<(), CameraError> {
        if frame >= MAX_FRAMES {
            return Err(CameraError::TooManyFrames);
        }
        let exposure_s = f64::from(EXPOSURE_US) * 1e-6;
        let end_s = frame as f64 / FPS;
        let (a, b) = if lit {
            (self.pixel_of(start_m)?, self.pixel_of(end_m)?)
        } else {
            // A dark LED is drawn where nothing can see it.
            let away = Point::new(-1e4, -1e4);
            (away, away)
        };
        let velocity_px_s = Point::new((b.x - a.x) / exposure_s, (b.y - a.y) / exposure_s);
        let trajectory = Trajectory::Line {
            start_px: Point::new(b.x - velocity_px_s.x * end_s, b.y - velocity_px_s.y * end_s),
            velocity_px_s,
        };
        self.scene
            .set_trajectory(trajectory)
            .map_err(CameraError::Scene)?;
        self.scene
            .render(frame, out)
            .map(|_| ())
            .map_err(CameraError::Scene)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rig::path::FigureEight;

    #[test]
    fn the_figure_eight_and_the_markers_are_in_view_about_1_5_m_away() {
        let camera = rig_camera();
        let [x, y, z] = camera.position_cm;
        let distance_m = (x * x + y * y + z * z).sqrt() / CM_PER_M;
        assert!((1.4..1.6).contains(&distance_m), "{distance_m}");
        let margin_px = 10.0;
        let inside = |p: FloorPoint| {
            let q = camera.project(p).unwrap();
            q.x > margin_px
                && q.y > margin_px
                && q.x < f64::from(WIDTH_PX) - margin_px
                && q.y < f64::from(HEIGHT_PX) - margin_px
        };
        for (x, y) in FigureEight::RIG.polyline() {
            assert!(
                inside(FloorPoint::new(x * CM_PER_M, y * CM_PER_M)),
                "{x} {y}"
            );
        }
        for m in rig_markers() {
            for c in m.corners_cm() {
                assert!(inside(c), "marker {} corner {c:?}", m.id);
            }
        }
    }

    #[test]
    fn the_led_is_drawn_where_the_robot_is_and_not_when_dark() {
        let mut cam = RigCamera::new(1).unwrap();
        let mut out = vec![0u8; cam.frame_len_bytes()];
        let at = (0.3, 0.1);
        cam.render(5, at, (0.302, 0.1), true, &mut out).unwrap();
        let px = cam.pixel_of(at).unwrap();
        let luma = |out: &[u8]| out[2 * (px.y.round() as usize * 640 + px.x.round() as usize)];
        assert!(luma(&out) > 250, "{}", luma(&out));
        cam.render(6, at, (0.302, 0.1), false, &mut out).unwrap();
        assert!(luma(&out) < 200, "{}", luma(&out));
    }
}
