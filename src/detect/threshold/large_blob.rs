//! Blobs larger than an LED's usual size: kept only when they moved since the last frame.
//!
//! A blob of the first cut larger than [`MAX_BLOB_FRACTION`](crate::detect::MAX_BLOB_FRACTION)
//! of the frame is most often glare (a window, a lamp in the lens), and a window whose noise
//! straddles its own level would break into thousands of specks if it were cut again. But an
//! LED in a wide glow makes a blob that large too: a 60 px streak in a glow that clips 40 px
//! around its path covers more than 2 % of a 640×480 frame. Its clipped pixels are all at the
//! clip, so no higher level separates its core from its glow; what tells it from a window is
//! that it moves.
//!
//! So a large blob is cut at its own level like any other only when it moved since the last
//! frame (the same rule the tracker applies to acquisition, here on the blobs of the first,
//! low cut): no blob of the last frame stood where it stands (its mass centre within
//! [`STOOD_PX`]), and a blob of the last frame of about its size
//! ([`SAME_LIGHT_AREA_RATIO`]) went away from where it stood (the same light, displaced). A
//! window, a lamp or a white frame stands still, and a lamp switched on came from nowhere, so
//! none of them is ever kept; in the first frame nothing is known to have moved. A large blob
//! that stops (an LED in a wide glow parked) is dropped again, as it was before; the static
//! map and the tracker's rules then never take a light that stood still since it appeared.
//! Of a large blob that stood still, only what has just come into it is kept (an LED touching
//! a window: see [`steady`](super::steady)).
//!
//! Cut at its own level, such a blob may leave more than one piece: over a textured floor a
//! darker seam under the glow cuts clipped islands off its edge. Of the pieces inside a large
//! blob that moved ([`MovedLarge`]) only the largest is the light; the others are its glow,
//! and a candidate beside the LED in its first frame would keep the tracker from taking it.
//!
//! Cost: the mass centres and areas of at most [`MAX_BLOBS`] blobs are kept a frame, and a
//! large blob is compared with each of them and each of them with this frame's blobs: a few
//! thousand distance tests at most, only in a frame with a large blob in it.

use heapless::Vec as BoundedVec;

use crate::detect::blobs::{Blob, BoundingBox, MAX_BLOBS};

/// A blob whose mass centre lies this close to where a blob of the last frame stood has stood
/// still: the mass centre of a blob hundreds of pixels large wanders by far less with noise,
/// while a moving LED's moves by its travel between frames.
pub const STOOD_PX: f32 = 2.0;

/// Two blobs of consecutive frames whose areas differ by at most this factor may be the same
/// light moved: a streak's area changes with its speed, by a few per cent from one frame to
/// the next, not twofold.
pub const SAME_LIGHT_AREA_RATIO: f32 = 2.0;

/// Where one blob of a first cut stood, and how large it was.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Place {
    centre_px: (f32, f32),
    area_px: u32,
}

impl Place {
    fn of(blob: &Blob) -> Self {
        Place {
            centre_px: blob.mass_centre_px,
            area_px: blob.area_px,
        }
    }

    fn stands_at(&self, centre_px: (f32, f32)) -> bool {
        let (dx, dy) = (
            self.centre_px.0 - centre_px.0,
            self.centre_px.1 - centre_px.1,
        );
        dx.hypot(dy) <= STOOD_PX
    }

    fn about_as_large_as(&self, area_px: u32) -> bool {
        let (a, b) = (self.area_px as f32, area_px as f32);
        a <= b * SAME_LIGHT_AREA_RATIO && b <= a * SAME_LIGHT_AREA_RATIO
    }
}

/// The blobs of the last frame's first cut; unknown before the first frame and after a frame
/// whose blobs did not fit in the tables.
#[derive(Debug, Default)]
pub struct LastBlobs {
    places: BoundedVec<Place, MAX_BLOBS>,
    known: bool,
}

impl LastBlobs {
    /// Nothing known of the last frame.
    pub fn new() -> Self {
        Self::default()
    }

    /// Whether `blob`, one of this frame's first-cut blobs `now`, moved since the last frame:
    /// nothing of the last frame stood where it stands, and a blob of the last frame about as
    /// large went away from where it stood (no blob of `now` stands there).
    pub fn moved(&self, blob: &Blob, now: &[Blob]) -> bool {
        if !self.known || self.places.iter().any(|p| p.stands_at(blob.mass_centre_px)) {
            return false;
        }
        self.places.iter().any(|p| {
            p.about_as_large_as(blob.area_px) && !now.iter().any(|b| p.stands_at(b.mass_centre_px))
        })
    }

    /// Remembers this frame's first-cut blobs for the next frame (all of them: the labeller
    /// holds at most [`MAX_BLOBS`]).
    pub fn remember(&mut self, now: &[Blob]) {
        self.places.clear();
        for blob in now {
            // At most MAX_BLOBS, as the labeller's own table.
            let _ = self.places.push(Place::of(blob));
        }
        self.known = true;
    }

    /// Forgets the last frame (its blobs overflowed the tables, or it had another size):
    /// nothing in the next frame is known to have moved.
    pub fn forget(&mut self) {
        self.places.clear();
        self.known = false;
    }
}

/// The extents of this frame's large first-cut blobs that moved.
#[derive(Debug, Default)]
pub struct MovedLarge {
    extents: BoundedVec<BoundingBox, MAX_BLOBS>,
}

impl MovedLarge {
    /// None yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Forgets the last frame's.
    pub fn clear(&mut self) {
        self.extents.clear();
    }

    /// Adds a large first-cut blob that moved.
    pub fn push(&mut self, blob: &Blob) {
        // At most one per first-cut blob, of which there are at most MAX_BLOBS.
        let _ = self.extents.push(blob.bbox);
    }

    /// True when `blob` (of the final mask) lies inside a large blob that moved: a piece of
    /// it, a candidate whatever its size.
    pub fn holds(&self, blob: &Blob) -> bool {
        self.extents.iter().any(|e| inside(&blob.bbox, e))
    }

    /// Marks in `glow` the blobs of `blobs` (the final mask's) that lie inside a large blob
    /// that moved and are not the largest piece there: its glow, cut apart.
    pub fn mark_glow_pieces(&self, blobs: &[Blob], glow: &mut [bool; MAX_BLOBS]) {
        glow.fill(false);
        for extent in &self.extents {
            let pieces = || {
                blobs
                    .iter()
                    .enumerate()
                    .filter(|(_, b)| inside(&b.bbox, extent))
            };
            let largest = pieces().max_by_key(|(_, b)| b.area_px).map(|(i, _)| i);
            for (i, _) in pieces().filter(|&(i, _)| Some(i) != largest) {
                if let Some(flag) = glow.get_mut(i) {
                    *flag = true;
                }
            }
        }
    }
}

/// True when box `a` lies inside box `b`.
fn inside(a: &BoundingBox, b: &BoundingBox) -> bool {
    a.x_min_px >= b.x_min_px
        && a.x_max_px <= b.x_max_px
        && a.y_min_px >= b.y_min_px
        && a.y_max_px <= b.y_max_px
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detect::blobs::BoundingBox;

    fn blob(x: f32, y: f32, area_px: u32) -> Blob {
        Blob {
            area_px,
            bbox: BoundingBox {
                x_min_px: x as usize - 1,
                y_min_px: y as usize - 1,
                x_max_px: x as usize + 1,
                y_max_px: y as usize + 1,
            },
            mass_centre_px: (x, y),
            elongation: 1.0,
        }
    }

    #[test]
    fn a_light_that_left_its_place_moved_and_one_that_stood_or_appeared_did_not() {
        let mut last = LastBlobs::new();
        let streak = blob(100.0, 100.0, 8000);
        assert!(
            !last.moved(&streak, &[streak]),
            "nothing known before the first frame"
        );
        let window = blob(400.0, 300.0, 9000);
        last.remember(&[streak, window]);
        // The streak 67 px on, the window where it was (its centre wandering by a pixel).
        let on = blob(160.0, 130.0, 8200);
        let window_now = blob(400.8, 299.5, 9100);
        let now = [on, window_now];
        assert!(last.moved(&on, &now));
        assert!(!last.moved(&window_now, &now), "the window stood still");
        // A lamp switched on elsewhere while everything else stands: it came from nowhere.
        last.remember(&now);
        let lamp = blob(500.0, 60.0, 7000);
        let now = [blob(160.0, 130.0, 8200), window_now, lamp];
        assert!(!last.moved(&lamp, &now));
        // A light of another size went away: not the same light.
        last.remember(&[blob(50.0, 50.0, 200), window_now]);
        let now = [window_now, lamp];
        assert!(
            !last.moved(&lamp, &now),
            "a small light went, a large one came"
        );
        // Forgotten (the tables overflowed): nothing moved.
        last.remember(&[streak]);
        last.forget();
        assert!(!last.moved(&on, &[on]));
    }

    #[test]
    fn of_the_pieces_inside_a_large_blob_that_moved_only_the_largest_is_the_light() {
        let mut large = blob(200.0, 200.0, 9000);
        large.bbox = BoundingBox {
            x_min_px: 150,
            y_min_px: 160,
            x_max_px: 250,
            y_max_px: 240,
        };
        let mut moved = MovedLarge::new();
        moved.push(&large);
        let light = blob(200.0, 200.0, 6000);
        let island = blob(240.0, 238.0, 12);
        let elsewhere = blob(400.0, 100.0, 30);
        let blobs = [island, light, elsewhere];
        let mut glow = [false; MAX_BLOBS];
        moved.mark_glow_pieces(&blobs, &mut glow);
        assert_eq!(glow[..3], [true, false, false]);
        assert!(moved.holds(&light) && moved.holds(&island) && !moved.holds(&elsewhere));
        moved.clear();
        moved.mark_glow_pieces(&blobs, &mut glow);
        assert_eq!(glow[..3], [false, false, false]);
    }
}
