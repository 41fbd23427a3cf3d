//! The axis of a straight streak's body, for the ramps' tips to lie on.
//!
//! The ramps ([`super::tips`]) read each end on its own: its centre across on one
//! cross-section through its cap, a few pixels long, and the direction out along the axis
//! from that and one more section 4 px back. The floor's texture and the noise move each of
//! those by a tenth of a pixel or two, at each end independently, and the walk out along a
//! slightly turned direction carries that further: on `fast-line`'s floor, 60 px streaks of
//! 1.5–4 px disks had their tips 0.12–0.16 px across the true path (root mean square over
//! twenty headings), where the middle is read on the whole streak's symmetry. A lens that
//! squeezes the spot obliquely to the path shears both caps, and moves the two tips across
//! the opposite ways (sweep seed 12's point 66: the head 0.3–0.6 px across in every frame,
//! the middle within 0.1 px).
//!
//! A straight streak's body, between its caps, is symmetric about the path wherever the spot
//! is swept along it, so the centres of many of its cross-sections lie on the path's line,
//! each read independently of the others. The line through them is the path's, and each tip
//! is moved across onto it (its place along the path is the ramps'). An arc is not straight:
//! where the centres bend away from a line by more than their own scatter says they might,
//! or where they scatter too much to tell, the tips stay as the ramps read them.

use super::level_falls::{first_falls, Armed};
use crate::frame::Frame;
use nalgebra::{Matrix3, Vector3};

/// Cross-sections of the body read. On 60 px streaks of 1.5–4 px disks, twelve put the tips
/// 0.05–0.09 px across the path; six and eight 0.06–0.11 px, sixteen 0.07–0.08 px.
const SECTIONS: usize = 12;

/// The fewest sections read whose centres a line is fitted to: fewer, and the body is not
/// one clean streak (a blob beside it, an edge that wanders).
const MIN_SECTIONS: usize = SECTIONS / 2;

/// The shortest body, between the caps, whose sections are read: on a shorter one twelve
/// sections lie closer than a pixel apart and read the same pixels.
const MIN_BODY_PX: f32 = 8.0;

/// How far inside the middle section's edge the walk to each section's edge starts, and half
/// how far it goes: a straight body's edge lies within a few tenths of a pixel of the
/// middle's, and a section whose edge is not within this of it is left out.
const SEEK_PX: f32 = 1.5;

/// A bend (the quadratic's sagitta at the body's ends) within this many of its own standard
/// deviations is the centres' scatter, not a bend.
const BEND_SIGMAS: f64 = 2.0;

/// A bend smaller than this is taken as straight whatever its deviation: it would move the
/// tips across by less than their own scatter.
const STRAIGHT_PX: f64 = 0.15;

/// The largest deviation of the bend for the centres to tell a straight body from an arc:
/// beyond it an arc that puts the tips half a pixel off the body's line would pass as
/// straight within [`BEND_SIGMAS`]. Over 60 px streaks of disks on `fast-line` the
/// deviation was 0.10 px in the median and at most 0.22 px; on a 17.6 px arc of radius
/// 77 px (sweep seed 13, point 111), 0.22–0.56 px.
const MAX_BEND_DEVIATION_PX: f64 = 0.25;

/// One side of the body as the ramps' middle cross-section read it.
#[derive(Clone, Copy, Debug)]
pub struct Side {
    /// The luma the edge is found at (the ramps' low level over that side's floor).
    pub level: f32,
    /// How far out from the axis the middle section's edge lay.
    pub edge_px: f32,
}

/// The axis of a straight streak's body: the line through the centres of its sections.
#[derive(Clone, Copy, Debug)]
pub struct BodyLine {
    /// A point on the line.
    origin_px: (f32, f32),
    /// Its unit direction.
    along: (f32, f32),
}

impl BodyLine {
    /// `p` moved across onto the line, where it lies along it.
    pub fn onto(self, p: (f32, f32)) -> (f32, f32) {
        let (dx, dy) = (p.0 - self.origin_px.0, p.1 - self.origin_px.1);
        let s = dx * self.along.0 + dy * self.along.1;
        (
            self.origin_px.0 + s * self.along.0,
            self.origin_px.1 + s * self.along.1,
        )
    }
}

/// The line through the centres of the body's sections between `ends_px` (points on the
/// axis near the streak's two ends), `inset_px` in from each, whose edges are found at the
/// `sides`' levels (`sides[0]` to the left of the direction from `ends_px[0]` to
/// `ends_px[1]`); `None` where the body is too short, too few sections were read, or it bends.
pub fn read(
    frame: &Frame<'_>,
    ends_px: [(f32, f32); 2],
    inset_px: f32,
    sides: [Side; 2],
) -> Option<BodyLine> {
    let chord = (ends_px[1].0 - ends_px[0].0, ends_px[1].1 - ends_px[0].1);
    let length_px = chord.0.hypot(chord.1);
    let body_px = length_px - 2.0 * inset_px;
    if body_px < MIN_BODY_PX {
        return None;
    }
    let u = (chord.0 / length_px, chord.1 / length_px);
    let n = (-u.1, u.0);
    let half_px = 0.5 * length_px;
    // Each section's centre (x along, from -1 to 1 between the ends; y across) summed into the
    // least squares of y on 1, x and x²: the quadratic tells a bend, its first two terms the
    // line.
    let mut sums = Sums::default();
    for j in 0..SECTIONS {
        let s = inset_px + body_px * (j as f32 + 0.5) / SECTIONS as f32;
        let p = (ends_px[0].0 + s * u.0, ends_px[0].1 + s * u.1);
        let [Some(left), Some(right)] =
            [(n, sides[0]), ((-n.0, -n.1), sides[1])].map(|(d, side)| edge_px(frame, p, d, side))
        else {
            continue;
        };
        sums.add(
            f64::from((s - half_px) / half_px),
            f64::from(0.5 * (left - right)),
        );
    }
    if sums.count < MIN_SECTIONS || sums.bends()? {
        return None;
    }
    // y = a + b·x through the centres: the point at the body's middle, and the slope.
    let line = sums.normal.fixed_view::<2, 2>(0, 0).try_inverse()? * sums.rhs.fixed_rows::<2>(0);
    let (a, slope) = (line[0] as f32, line[1] as f32 / half_px);
    let along = (u.0 + slope * n.0, u.1 + slope * n.1);
    let norm = along.0.hypot(along.1);
    Some(BodyLine {
        origin_px: (
            ends_px[0].0 + half_px * u.0 + a * n.0,
            ends_px[0].1 + half_px * u.1 + a * n.1,
        ),
        along: (along.0 / norm, along.1 / norm),
    })
}

/// How far out from `p` along `d` the luma falls through `side.level`, sought within
/// [`SEEK_PX`] of where the middle section's edge lay.
fn edge_px(frame: &Frame<'_>, p: (f32, f32), d: (f32, f32), side: Side) -> Option<f32> {
    let from_px = (side.edge_px - SEEK_PX).max(0.0);
    let start = (p.0 + from_px * d.0, p.1 + from_px * d.1);
    let [fall] = first_falls(
        frame,
        start,
        d,
        &[side.level],
        2.0 * SEEK_PX,
        Armed::AtStart,
    );
    fall.map(|f| from_px + f.at_px)
}

/// The sums of the least squares of the sections' centres `y` on `1`, `x` and `x²`.
#[derive(Default)]
struct Sums {
    normal: Matrix3<f64>,
    rhs: Vector3<f64>,
    squares: f64,
    count: usize,
}

impl Sums {
    fn add(&mut self, x: f64, y: f64) {
        let basis = Vector3::new(1.0, x, x * x);
        self.normal += basis * basis.transpose();
        self.rhs += basis * y;
        self.squares += y * y;
        self.count += 1;
    }

    /// Whether the centres bend away from a line: the quadratic `a + b·x + c·x²` through them
    /// stands `c` off the line at the ends (x = ±1). `None` when the bend cannot be told from
    /// their scatter.
    fn bends(&self) -> Option<bool> {
        let inverse = self.normal.try_inverse()?;
        let fit = inverse * self.rhs;
        let residual = (self.squares - fit.dot(&self.rhs)).max(0.0);
        let variance = residual / (self.count as f64 - 3.0);
        let bend_deviation_px = (variance * inverse[(2, 2)]).sqrt();
        if bend_deviation_px > MAX_BEND_DEVIATION_PX {
            return None;
        }
        Some(fit[2].abs() > STRAIGHT_PX.max(BEND_SIGMAS * bend_deviation_px))
    }
}
