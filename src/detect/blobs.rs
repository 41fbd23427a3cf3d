//! Connected blobs of a mask, found through its runs, in bounded memory.
//!
//! A row of the mask is scanned a word at a time into runs (maximal horizontal stretches of set
//! pixels). Runs that touch runs of the previous row, diagonals included (8-connectivity), are
//! joined in a union-find whose root is always the earliest run, so one forward pass assigns
//! every blob a slot. Work and memory are bounded by [`MAX_RUNS`] and [`MAX_BLOBS`]: a frame
//! with more (sun through a window, a light switched on) is reported as overflowing instead of
//! slowing down or growing anything.

use core::fmt;

use heapless::Vec as BoundedVec;

use super::bitimage::{BitImage, WORD_BITS};

/// The most runs one frame may hold. An LED streak needs tens; a glare spot tens more.
pub const MAX_RUNS: usize = 8192;

/// The most blobs one frame may hold.
pub const MAX_BLOBS: usize = 64;

/// An inclusive pixel rectangle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BoundingBox {
    pub x_min_px: usize,
    pub y_min_px: usize,
    pub x_max_px: usize,
    pub y_max_px: usize,
}

impl BoundingBox {
    /// Width in pixels.
    pub fn width_px(&self) -> usize {
        self.x_max_px - self.x_min_px + 1
    }

    /// Height in pixels.
    pub fn height_px(&self) -> usize {
        self.y_max_px - self.y_min_px + 1
    }
}

/// One connected blob of the mask.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Blob {
    /// Set pixels.
    pub area_px: u32,
    /// Its extent.
    pub bbox: BoundingBox,
    /// Mean of its pixel centres (the seed's mass centre, binary).
    pub mass_centre_px: (f32, f32),
    /// How much longer than wide the blob is: the ratio of its principal second moments
    /// (1 for a disk; grows with the length of a streak).
    pub elongation: f32,
}

#[cfg(test)]
impl Blob {
    /// A round blob of one pixel's area whose box is `x0..=x1`, `y0..=y1`: for the tests of
    /// what reads only a blob's box (the light the floor is not learned under).
    pub(crate) fn boxed(x0: usize, y0: usize, x1: usize, y1: usize) -> Blob {
        Blob {
            area_px: 1,
            bbox: BoundingBox {
                x_min_px: x0,
                y_min_px: y0,
                x_max_px: x1,
                y_max_px: y1,
            },
            mass_centre_px: (0.5 * (x0 + x1) as f32, 0.5 * (y0 + y1) as f32),
            elongation: 1.0,
        }
    }
}

/// A horizontal run of set pixels, `x0..=x1` on row `y`.
#[derive(Debug, Clone, Copy)]
pub struct Run {
    pub y: u16,
    pub x0: u16,
    pub x1: u16,
    parent: u16,
    slot: u16,
}

impl Run {
    /// The index of the blob this run belongs to, or `None` when the blob did not fit in the
    /// list.
    pub fn blob(&self) -> Option<usize> {
        (self.slot != NO_SLOT).then_some(usize::from(self.slot))
    }
}

/// Why labelling stopped short.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Overflow {
    /// More than [`MAX_RUNS`] runs: rows after the limit were not labelled.
    pub runs: bool,
    /// More than [`MAX_BLOBS`] blobs: the later ones were dropped.
    pub blobs: bool,
}

impl Overflow {
    /// True when anything was cut.
    pub fn any(&self) -> bool {
        self.runs || self.blobs
    }
}

impl fmt::Display for Overflow {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match (self.runs, self.blobs) {
            (true, _) => write!(f, "more than {MAX_RUNS} mask runs in one frame"),
            (false, true) => write!(f, "more than {MAX_BLOBS} blobs in one frame"),
            (false, false) => write!(f, "no overflow"),
        }
    }
}

/// The blob finder, with its bounded tables allocated once.
pub struct Labeler {
    runs: Box<BoundedVec<Run, MAX_RUNS>>,
    blobs: BoundedVec<Blob, MAX_BLOBS>,
    overflow: Overflow,
}

impl Default for Labeler {
    fn default() -> Self {
        Self::new()
    }
}

/// No slot: a run whose blob did not fit in the list.
const NO_SLOT: u16 = u16::MAX;

// Run indices and blob slots are stored as u16, with NO_SLOT kept free.
const _: () = assert!(MAX_RUNS < NO_SLOT as usize);

impl Labeler {
    /// Allocates the run table (about 80 KiB) once.
    pub fn new() -> Self {
        Labeler {
            runs: Box::new(BoundedVec::new()),
            blobs: BoundedVec::new(),
            overflow: Overflow::default(),
        }
    }

    /// Finds the blobs of `mask`, replacing the previous result.
    pub fn label(&mut self, mask: &BitImage) {
        self.runs.clear();
        self.blobs.clear();
        self.overflow = Overflow::default();
        let mut prev_row = 0..0;
        for y in 0..mask.height() {
            let row_start = self.runs.len();
            if !self.push_row_runs(mask.row(y), y) {
                self.overflow.runs = true;
                break;
            }
            let row = row_start..self.runs.len();
            self.join_with_previous(prev_row, row.clone());
            prev_row = row;
        }
        self.assign_slots();
    }

    /// The blobs found, in order of their first pixel (top to bottom, left to right).
    pub fn blobs(&self) -> &[Blob] {
        &self.blobs
    }

    /// What did not fit.
    pub fn overflow(&self) -> Overflow {
        self.overflow
    }

    /// Every run of the last labelled mask, top to bottom.
    pub fn runs(&self) -> &[Run] {
        &self.runs
    }

    /// The runs of blob `index`, top to bottom.
    pub fn runs_of(&self, index: usize) -> impl Iterator<Item = &Run> + '_ {
        self.runs
            .iter()
            .filter(move |run| usize::from(run.slot) == index)
    }

    /// Appends the runs of one mask row; false when the table is full.
    fn push_row_runs(&mut self, words: &[u64], y: usize) -> bool {
        let row_start = self.runs.len();
        for (k, &word) in words.iter().enumerate() {
            let mut bits = word;
            while bits != 0 {
                let start = bits.trailing_zeros() as usize;
                let len = (!(bits >> start)).trailing_zeros() as usize;
                let x0 = k * WORD_BITS + start;
                let x1 = x0 + len - 1;
                bits = if start + len >= WORD_BITS {
                    0
                } else {
                    bits & (!0u64 << (start + len))
                };
                // A run that ended on the last bit of the previous word continues here.
                let in_this_row = self.runs.len() > row_start;
                if let Some(last) = self.runs.last_mut().filter(|_| in_this_row) {
                    if usize::from(last.x1) + 1 == x0 {
                        last.x1 = x1 as u16;
                        continue;
                    }
                }
                let index = self.runs.len() as u16;
                let run = Run {
                    y: y as u16,
                    x0: x0 as u16,
                    x1: x1 as u16,
                    parent: index,
                    slot: NO_SLOT,
                };
                if self.runs.push(run).is_err() {
                    return false;
                }
            }
        }
        true
    }

    /// Unions each run of `row` with the runs of `prev` it touches, diagonals included.
    fn join_with_previous(&mut self, prev: core::ops::Range<usize>, row: core::ops::Range<usize>) {
        let mut p = prev.start;
        for r in row {
            let (x0, x1) = (self.runs[r].x0, self.runs[r].x1);
            // Skip previous runs that end left of this one's diagonal reach.
            while p < prev.end && self.runs[p].x1 + 1 < x0 {
                p += 1;
            }
            let mut q = p;
            while q < prev.end && self.runs[q].x0 <= x1 + 1 {
                self.union(q, r);
                q += 1;
            }
        }
    }

    fn find(&mut self, mut i: usize) -> usize {
        while usize::from(self.runs[i].parent) != i {
            let grandparent = self.runs[usize::from(self.runs[i].parent)].parent;
            self.runs[i].parent = grandparent;
            i = usize::from(grandparent);
        }
        i
    }

    fn union(&mut self, a: usize, b: usize) {
        let (ra, rb) = (self.find(a), self.find(b));
        // The earlier run stays the root, so roots precede their members in the table.
        let (root, child) = if ra < rb { (ra, rb) } else { (rb, ra) };
        self.runs[child].parent = root as u16;
    }

    /// Gives every root a blob slot and sums each blob's statistics.
    fn assign_slots(&mut self) {
        let mut sums = [Moments::default(); MAX_BLOBS];
        for i in 0..self.runs.len() {
            let root = self.find(i);
            let slot = if root == i {
                let slot = self.blobs.len();
                let run = self.runs[i];
                let blob = Blob {
                    area_px: 0,
                    bbox: BoundingBox {
                        x_min_px: run.x0.into(),
                        y_min_px: run.y.into(),
                        x_max_px: run.x1.into(),
                        y_max_px: run.y.into(),
                    },
                    mass_centre_px: (0.0, 0.0),
                    elongation: 1.0,
                };
                if self.blobs.push(blob).is_err() {
                    self.overflow.blobs = true;
                    NO_SLOT
                } else {
                    slot as u16
                }
            } else {
                self.runs[root].slot
            };
            self.runs[i].slot = slot;
            let run = self.runs[i];
            let (Some(blob), Some(sum)) = (
                self.blobs.get_mut(usize::from(slot)),
                sums.get_mut(usize::from(slot)),
            ) else {
                continue;
            };
            blob.area_px += u32::from(run.x1 - run.x0) + 1;
            sum.add_run(run);
            let b = &mut blob.bbox;
            b.x_min_px = b.x_min_px.min(run.x0.into());
            b.x_max_px = b.x_max_px.max(run.x1.into());
            b.y_max_px = b.y_max_px.max(run.y.into());
        }
        for (blob, sum) in self.blobs.iter_mut().zip(sums.iter()) {
            let (centre, elongation) = sum.shape();
            blob.mass_centre_px = centre;
            blob.elongation = elongation;
        }
    }
}

/// Raw moments of a blob's pixel centres, summed run by run in closed form.
#[derive(Debug, Clone, Copy, Default)]
struct Moments {
    n: f64,
    sx: f64,
    sy: f64,
    sxx: f64,
    syy: f64,
    sxy: f64,
}

impl Moments {
    fn add_run(&mut self, run: Run) {
        let (x0, x1, y) = (f64::from(run.x0), f64::from(run.x1), f64::from(run.y));
        let n = x1 - x0 + 1.0;
        let sx = n * (x0 + x1) / 2.0;
        // Σ x² over x0..=x1, from the sum of squares 1..=m.
        let squares = |m: f64| m * (m + 1.0) * (2.0 * m + 1.0) / 6.0;
        let sxx = squares(x1) - squares(x0 - 1.0);
        self.n += n;
        self.sx += sx;
        self.sy += n * y;
        self.sxx += sxx;
        self.syy += n * y * y;
        self.sxy += sx * y;
    }

    /// The mass centre, and the ratio of the principal variances.
    fn shape(&self) -> ((f32, f32), f32) {
        if self.n <= 0.0 {
            return ((0.0, 0.0), 1.0);
        }
        let (mx, my) = (self.sx / self.n, self.sy / self.n);
        // A pixel is a unit square: add its own variance, 1/12, so single rows are not lines
        // of zero width.
        let cxx = self.sxx / self.n - mx * mx + 1.0 / 12.0;
        let cyy = self.syy / self.n - my * my + 1.0 / 12.0;
        let cxy = self.sxy / self.n - mx * my;
        let half_trace = 0.5 * (cxx + cyy);
        let spread = (0.25 * (cxx - cyy).powi(2) + cxy * cxy).sqrt();
        let elongation = (half_trace + spread) / (half_trace - spread).max(f64::EPSILON);
        ((mx as f32, my as f32), elongation as f32)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn label(picture: &[&str]) -> Labeler {
        let mut labeler = Labeler::new();
        labeler.label(&BitImage::from_ascii(picture));
        labeler
    }

    #[test]
    fn diagonal_neighbours_join_and_gaps_separate() {
        let l = label(&[
            "##...#", //
            "..#..#", "...#..", "......", "#....#",
        ]);
        let areas: Vec<u32> = l.blobs().iter().map(|b| b.area_px).collect();
        // The diagonal chain, the right column (two columns away from the chain), two dots.
        assert_eq!(areas, vec![4, 2, 1, 1]);
        assert!(!l.overflow().any());
    }

    #[test]
    fn u_shapes_merge_into_one_blob_with_the_right_statistics() {
        let l = label(&[
            "#...#", //
            "#...#", "#####",
        ]);
        assert_eq!(l.blobs().len(), 1);
        let blob = l.blobs()[0];
        assert_eq!(blob.area_px, 9);
        assert_eq!(
            blob.bbox,
            BoundingBox {
                x_min_px: 0,
                y_min_px: 0,
                x_max_px: 4,
                y_max_px: 2
            }
        );
        // x: (0+4)*2 + (0+1+2+3+4) = 18 over 9; y: 0*2 + 1*2 + 2*5 = 12 over 9.
        assert_eq!(blob.mass_centre_px, (2.0, 12.0 / 9.0));
        assert!(blob.elongation > 1.0);
        assert_eq!(l.runs_of(0).count(), 5);
    }

    #[test]
    fn a_streak_is_elongated_and_a_disk_is_not() {
        let l = label(&[
            "..###..........",
            ".#####.........",
            ".#####...######",
            ".#####...######",
            "..###....######",
        ]);
        let disk = l.blobs()[0];
        let streak = l.blobs()[1];
        assert!(disk.elongation < 1.1, "{}", disk.elongation);
        // 6 × 3 pixels: variances (36/12) and (9/12), a ratio of 4.
        assert!(
            (streak.elongation - 4.0).abs() < 1e-4,
            "{}",
            streak.elongation
        );
    }

    #[test]
    fn runs_continue_across_word_boundaries() {
        let mut mask = BitImage::with_dimensions(200, 1);
        for x in 60..140 {
            mask.set(x, 0);
        }
        let mut l = Labeler::new();
        l.label(&mask);
        assert_eq!(l.blobs().len(), 1);
        assert_eq!(l.runs_of(0).count(), 1);
        assert_eq!(l.blobs()[0].area_px, 80);
        assert_eq!(l.blobs()[0].mass_centre_px.0, 99.5);
    }

    #[test]
    fn too_many_blobs_or_runs_are_reported_not_fatal() {
        // A checkerboard of isolated pixels on every other row: many blobs, many runs.
        let mut mask = BitImage::with_dimensions(640, 480);
        for y in (0..480).step_by(2) {
            for x in (0..640).step_by(2) {
                mask.set(x, y);
            }
        }
        let mut l = Labeler::new();
        l.label(&mask);
        assert!(l.overflow().runs && l.overflow().blobs);
        assert_eq!(l.blobs().len(), MAX_BLOBS);
        // The labeller recovers on the next, clean frame.
        mask.clear_all();
        mask.set(5, 5);
        l.label(&mask);
        assert!(!l.overflow().any());
        assert_eq!(l.blobs().len(), 1);
    }
}
