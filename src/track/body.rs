//! The other lights of a tracked LED's body (another LED of the same robot), so that while
//! the LED is lost one of them is not taken for it.
//!
//! A light is another light of the body only once it has been *shown to move with the LED*:
//! seen beside the found LED in [`COMPANION_FRAMES`] frames, each time where the LED's own
//! displacement since the last sighting carries it (within half that displacement, or
//! [`DRIFT_PX`] for a slow LED), and, over those frames, displaced like the LED by more than
//! [`DRIFT_PX`]. Being seen beside the LED once proves nothing: a fragment of the LED's own
//! blob (a dim streak split by the level) is beside it for one frame, and a window, a lamp or
//! a static fragment of them never moves with it (its displacement differs from the LED's by
//! the whole of the LED's). Lights of a body that turns fast enough to move them by more
//! than half the LED's displacement relative to it are not recognised; the tracker then
//! behaves as for a lone LED.
//!
//! While the LED is lost the lights are carried on from where they were last seen beside it,
//! at the LED's velocity ([`Body::explains`]). Each light explains one blob, the one nearest
//! where it is carried: the LED back beside its lights is the blob none of them claims. A
//! blob seen while the LED is lost never moves a light by itself: a blob refused as the LED
//! because a light explains it would otherwise feed that light, and the refusal renew itself
//! frame after frame. Only two or more lights seen where the body, shifted as one, puts them
//! ([`Body::follow`]) move the body, and with it where the LED is expected: on a curve the
//! LED's straight prediction drifts off, while its lights show where the body went.

use heapless::Vec as BoundedVec;

use super::statics::DRIFT_PX;
use super::{dist, MAX_MISSED_FRAMES};

/// Lights remembered beside one LED: those of its body and, until they fail to move with it,
/// anything else beside it. Extra lights beyond this in one frame are not remembered.
pub const MAX_LIGHTS: usize = 8;

/// Frames a light must be seen moving with the found LED before it counts as a light of the
/// body: two steps, so that one coincidence (a fragment of the LED itself) is not enough.
pub const COMPANION_FRAMES: u32 = 3;

// The lights continued in a frame are marked in one `u32`.
const _: () = assert!(MAX_LIGHTS <= 32);

#[derive(Debug, Clone, Copy, PartialEq)]
struct Light {
    /// Where it was last seen, in frame `seen_frame`, beside the LED at `led_px`.
    position_px: (f32, f32),
    seen_frame: u64,
    led_px: (f32, f32),
    /// Where it and the LED were when it was first seen moving with it.
    origin_px: (f32, f32),
    led_origin_px: (f32, f32),
    /// Frames seen moving with the LED, from that first one.
    frames: u32,
}

impl Light {
    /// It has been shown to move with the LED: seen with it for [`COMPANION_FRAMES`] frames,
    /// displaced like it by more than [`DRIFT_PX`] over them.
    fn moves_with_led(&self) -> bool {
        let led = (
            self.led_px.0 - self.led_origin_px.0,
            self.led_px.1 - self.led_origin_px.1,
        );
        let own = (
            self.position_px.0 - self.origin_px.0,
            self.position_px.1 - self.origin_px.1,
        );
        let led_px = led.0.hypot(led.1);
        self.frames >= COMPANION_FRAMES && led_px > DRIFT_PX && dist(own, led) <= 0.5 * led_px
    }
}

/// A light of the body carried on to a frame while the LED is lost.
#[derive(Debug, Clone, Copy)]
struct Carried {
    /// Where it lands.
    at_px: (f32, f32),
    /// From there to the blob nearest it, when one is near enough.
    shift_px: Option<(f32, f32)>,
}

/// The lights seen moving with one tracked LED.
#[derive(Debug, Default)]
pub struct Body {
    lights: BoundedVec<Light, MAX_LIGHTS>,
    /// The table being built from a frame, swapped with `lights` at its end.
    next: BoundedVec<Light, MAX_LIGHTS>,
}

impl Body {
    /// True when some light has been shown to move with the LED.
    pub fn has_lights(&self) -> bool {
        self.lights.iter().any(Light::moves_with_led)
    }

    /// Forgets every light: a new track has no body yet.
    pub fn clear(&mut self) {
        self.lights.clear();
    }

    /// Where each light of the body (shown to move with the LED) lands in frame
    /// `frame_index`, carried on by `step_px` a frame since it was last seen beside the LED
    /// (see [`recent`]), with its index in the table.
    fn carried(
        &self,
        frame_index: u64,
        step_px: (f32, f32),
    ) -> impl Iterator<Item = (usize, (f32, f32))> + '_ {
        self.lights
            .iter()
            .enumerate()
            .filter(move |(_, l)| l.moves_with_led() && recent(l.seen_frame, frame_index))
            .map(move |(index, l)| {
                let frames = frame_index.saturating_sub(l.seen_frame) as f32;
                let carried = (
                    l.position_px.0 + step_px.0 * frames,
                    l.position_px.1 + step_px.1 * frames,
                );
                (index, carried)
            })
    }

    /// While the LED is lost, in frame `frame_index`: each light of the body, carried on by
    /// `step_px` a frame, is matched to the blob (of `blobs`) nearest it within `gate_px`.
    /// When two or more are matched and their shifts from where they were carried agree
    /// (within half the distance of the nearest light from the LED, beyond which a blob's
    /// identity is in doubt), the body moved as one by their mean shift: every light of it is
    /// moved so, and the LED's place that their matches imply is returned. One light alone,
    /// or lights that disagree (one of them matched the LED itself, or something else), move
    /// nothing.
    pub fn follow(
        &mut self,
        frame_index: u64,
        step_px: (f32, f32),
        gate_px: f32,
        blobs: impl Iterator<Item = (f32, f32)> + Clone,
    ) -> Option<(f32, f32)> {
        let mut found: [Option<Carried>; MAX_LIGHTS] = [None; MAX_LIGHTS];
        let mut nearest_offset_px = f32::INFINITY;
        for (index, carried) in self.carried(frame_index, step_px) {
            let (Some(light), Some(slot)) = (self.lights.get(index), found.get_mut(index)) else {
                continue;
            };
            nearest_offset_px = nearest_offset_px.min(dist(light.position_px, light.led_px));
            let shift = blobs
                .clone()
                .map(|p| (p, dist(p, carried)))
                .filter(|&(_, d)| d <= gate_px)
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .map(|(p, _)| (p.0 - carried.0, p.1 - carried.1));
            *slot = Some(Carried {
                at_px: carried,
                shift_px: shift,
            });
        }
        let shifts = || found.iter().flatten().filter_map(|c| c.shift_px);
        let count = shifts().count();
        let agree = shifts().all(|a| shifts().all(|b| dist(a, b) <= 0.5 * nearest_offset_px));
        if count < 2 || !agree {
            return None;
        }
        let n = count as f32;
        let shift = shifts().fold((0.0, 0.0), |s, d| (s.0 + d.0 / n, s.1 + d.1 / n));
        let mut led_sum_px = (0.0, 0.0);
        for (light, slot) in self.lights.iter_mut().zip(found.iter()) {
            let Some(Carried {
                at_px: carried,
                shift_px: own_shift,
            }) = *slot
            else {
                continue;
            };
            // The light and the LED's place beside it move together, so that it still moves
            // with the LED once the LED is back.
            let moved_to = (carried.0 + shift.0, carried.1 + shift.1);
            let offset = (
                light.position_px.0 - light.led_px.0,
                light.position_px.1 - light.led_px.1,
            );
            light.position_px = moved_to;
            light.led_px = (moved_to.0 - offset.0, moved_to.1 - offset.1);
            light.seen_frame = frame_index;
            if let Some(own) = own_shift {
                // Where this light's own blob puts the LED.
                led_sum_px.0 += carried.0 + own.0 - offset.0;
                led_sum_px.1 += carried.1 + own.1 - offset.1;
            }
        }
        Some((led_sum_px.0 / n, led_sum_px.1 / n))
    }

    /// True when the blob at `position_px`, one of `blobs` (every candidate's place in frame
    /// `frame_index`), is another light of the body rather than the LED, whose prediction lies
    /// `led_distance_px` from it: some light of the body, carried on by `step_px` a frame,
    /// lands nearer it than the prediction, and no other blob is nearer that light. With no
    /// light of the body (a lone LED), never.
    pub fn explains(
        &self,
        position_px: (f32, f32),
        led_distance_px: f32,
        frame_index: u64,
        step_px: (f32, f32),
        blobs: impl Iterator<Item = (f32, f32)> + Clone,
    ) -> bool {
        self.carried(frame_index, step_px).any(|(_, carried)| {
            let d = dist(carried, position_px);
            d < led_distance_px && blobs.clone().all(|p| dist(carried, p) >= d)
        })
    }

    /// Notes the blobs at `others` seen in frame `frame_index` beside the LED, found at
    /// `led_px` (its blob's mass centre). Each continues the light it is carried onto by the
    /// LED's displacement since that light was seen, within half that displacement (or
    /// [`DRIFT_PX`]); the rest start anew. Lights of the body not seen now are kept, to be
    /// carried on while they are hidden; anything else not seen now is dropped. When more than
    /// [`MAX_LIGHTS`] are seen (a window broken into specks beside the LED), the lights that
    /// continue one and the body's are kept first, then the new ones nearest the LED.
    pub fn observe(
        &mut self,
        frame_index: u64,
        led_px: (f32, f32),
        others: impl Iterator<Item = (f32, f32)> + Clone,
    ) {
        self.next.clear();
        // Which lights of the table were continued, by index.
        let mut continued_lights = 0u32;
        for here in others.clone() {
            if let Some((index, l)) = self.continued(frame_index, led_px, here) {
                continued_lights |= 1 << index;
                let light = Light {
                    position_px: here,
                    seen_frame: frame_index,
                    led_px,
                    frames: l.frames.saturating_add(1),
                    ..l
                };
                // Beyond MAX_LIGHTS, the rest are not remembered.
                let _ = self.next.push(light);
            }
        }
        for (index, l) in self.lights.iter().enumerate() {
            let kept = continued_lights & (1 << index) == 0
                && l.moves_with_led()
                && recent(l.seen_frame, frame_index);
            if kept {
                let _ = self.next.push(*l);
            }
        }
        for here in others {
            if self.continued(frame_index, led_px, here).is_none() {
                let light = Light {
                    position_px: here,
                    seen_frame: frame_index,
                    led_px,
                    origin_px: here,
                    led_origin_px: led_px,
                    frames: 1,
                };
                // A full table keeps the new lights nearest the LED.
                if let Err(light) = self.next.push(light) {
                    let farthest = self
                        .next
                        .iter_mut()
                        .filter(|n| n.frames == 1)
                        .max_by(|a, b| {
                            dist(a.position_px, led_px).total_cmp(&dist(b.position_px, led_px))
                        });
                    if let Some(n) = farthest {
                        if dist(n.position_px, led_px) > dist(here, led_px) {
                            *n = light;
                        }
                    }
                }
            }
        }
        core::mem::swap(&mut self.lights, &mut self.next);
    }

    /// The light (index in the table, and the light) that a blob at `here`, seen in frame
    /// `frame_index` beside the LED at `led_px`, continues: the one the LED's displacement
    /// since it was seen carries nearest `here`, within half that displacement (or
    /// [`DRIFT_PX`]). None when a light stands where `here` is at least as well: a blob that
    /// may simply have stayed (one of a row of lamps spaced like the LED's step) has not been
    /// shown to move.
    fn continued(
        &self,
        frame_index: u64,
        led_px: (f32, f32),
        here: (f32, f32),
    ) -> Option<(usize, Light)> {
        let recent_lights = || {
            self.lights
                .iter()
                .enumerate()
                .filter(|(_, l)| recent(l.seen_frame, frame_index))
        };
        let (index, light, carried_px) = recent_lights()
            .map(|(index, l)| {
                let led_step = (led_px.0 - l.led_px.0, led_px.1 - l.led_px.1);
                let carried = (l.position_px.0 + led_step.0, l.position_px.1 + led_step.1);
                let tolerance_px = DRIFT_PX.max(0.5 * led_step.0.hypot(led_step.1));
                (index, l, dist(carried, here), tolerance_px)
            })
            .filter(|&(_, _, d, tolerance_px)| d <= tolerance_px)
            .min_by(|a, b| a.2.total_cmp(&b.2))
            .map(|(index, l, d, _)| (index, *l, d))?;
        let stayed = recent_lights().any(|(_, l)| dist(l.position_px, here) <= carried_px);
        (!stayed).then_some((index, light))
    }
}

/// True when a light last seen in frame `seen_frame` (or moved there with its body, in this
/// frame) may still be carried on in frame `frame_index`: for as long as the LED's track is
/// predicted after its last found frame ([`MAX_MISSED_FRAMES`] frames missed, and the one
/// after, in which it is dropped).
fn recent(seen_frame: u64, frame_index: u64) -> bool {
    frame_index.saturating_sub(seen_frame) <= u64::from(MAX_MISSED_FRAMES) + 1
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The LED at `led`, with lights at `others`, in frame `i`.
    fn seen(b: &mut Body, i: u64, led: (f32, f32), others: &[(f32, f32)]) {
        b.observe(i, led, others.iter().copied());
    }

    #[test]
    fn a_light_moving_with_the_led_for_three_frames_is_of_its_body() {
        let mut b = Body::default();
        let led = |i: u64| (100.0 + 10.0 * i as f32, 100.0);
        let other = |i: u64| (led(i).0 + 20.0, 100.0);
        for i in 0..2 {
            seen(&mut b, i, led(i), &[other(i)]);
            // Two frames prove nothing yet.
            assert!(!b.explains(
                other(i + 1),
                20.0,
                i + 1,
                (10.0, 0.0),
                [other(i + 1)].into_iter()
            ));
        }
        seen(&mut b, 2, led(2), &[other(2)]);
        // Lost in frame 3: the light, carried on, explains the blob where it is.
        let blobs = [other(3)];
        assert!(b.explains(other(3), 20.0, 3, (10.0, 0.0), blobs.into_iter()));
        // The LED itself, back at its prediction, is not that light.
        let blobs = [led(3), other(3)];
        assert!(!b.explains(led(3), 0.5, 3, (10.0, 0.0), blobs.into_iter()));
        // Alone, 1 px nearer the light's place than the prediction, the one blob is the light;
        // beside the light's own blob, the light claims its own.
        let between = (led(3).0 + 10.5, 100.0);
        assert!(b.explains(between, 10.5, 3, (10.0, 0.0), [between].into_iter()));
        let both = [between, other(3)];
        assert!(!b.explains(between, 10.5, 3, (10.0, 0.0), both.into_iter()));
        // Carried no longer than a track is predicted.
        let late = 2 + u64::from(MAX_MISSED_FRAMES) + 2;
        assert!(!b.explains(
            other(late),
            100.0,
            late,
            (10.0, 0.0),
            [other(late)].into_iter()
        ));
    }

    #[test]
    fn a_static_light_and_a_fragment_seen_once_are_not() {
        let mut b = Body::default();
        // A lamp beside the LED all along, and in frame 4 a fragment of the LED's own blob.
        let lamp = (300.0, 100.0);
        let led = |i: u64| (100.0 + 1.5 * i as f32, 100.0);
        for i in 0..10 {
            let fragment = (led(i).0 + 3.0, 101.0);
            let others: &[(f32, f32)] = if i == 4 { &[lamp, fragment] } else { &[lamp] };
            seen(&mut b, i, led(i), others);
        }
        assert!(!b.explains(lamp, 200.0, 10, (1.5, 0.0), [lamp].into_iter()));
        let fragment = (led(10).0 + 3.0, 101.0);
        assert!(!b.explains(fragment, 3.0, 10, (1.5, 0.0), [fragment].into_iter()));
        // Nor a light that wanders off relative to the LED.
        let mut b = Body::default();
        for i in 0..10 {
            let wanderer = (200.0 + 10.0 * i as f32, 100.0 + 6.0 * i as f32);
            seen(&mut b, i, (100.0 + 10.0 * i as f32, 100.0), &[wanderer]);
        }
        let wanderer = (300.0, 160.0);
        assert!(!b.explains(wanderer, 200.0, 10, (10.0, 0.0), [wanderer].into_iter()));
    }

    #[test]
    fn what_is_seen_while_the_led_is_lost_never_moves_a_light() {
        let mut b = Body::default();
        let led = |i: u64| (100.0 + 10.0 * i as f32, 100.0);
        for i in 0..4 {
            seen(&mut b, i, led(i), &[(led(i).0 + 20.0, 100.0)]);
        }
        // Lost from frame 4 on: nothing is observed, and the light is carried from frame 3.
        let carried = |i: u64| (led(3).0 + 20.0 + 10.0 * (i - 3) as f32, 100.0);
        for i in 4..8 {
            assert!(b.explains(carried(i), 20.0, i, (10.0, 0.0), [carried(i)].into_iter()));
        }
        // Found again: a light flickered off for a frame is kept and carried meanwhile.
        seen(&mut b, 8, led(8), &[]);
        assert!(b.explains(carried(9), 20.0, 9, (10.0, 0.0), [carried(9)].into_iter()));
        b.clear();
        assert!(!b.explains(carried(9), 20.0, 9, (10.0, 0.0), [carried(9)].into_iter()));
    }
    #[test]
    fn two_lights_that_agree_move_the_body_and_one_alone_does_not() {
        // Two lights 20 px right of and 20 px below the LED, all moving 10 px a frame right.
        let offsets = [(20.0, 0.0), (0.0, 20.0)];
        let led = |i: u64| (100.0 + 10.0 * i as f32, 100.0);
        let at = |i: u64, o: (f32, f32)| (led(i).0 + o.0, led(i).1 + o.1);
        let trained = || {
            let mut b = Body::default();
            for i in 0..4 {
                seen(&mut b, i, led(i), &offsets.map(|o| at(i, o)));
            }
            b
        };
        // Lost in frame 4, the body turned: it is 6 px lower than carried on straight.
        let turned = |o: (f32, f32)| (at(4, o).0, at(4, o).1 + 6.0);
        let step = (10.0, 0.0);
        let mut b = trained();
        let both = offsets.map(turned);
        let led_px = b.follow(4, step, 50.0, both.into_iter()).unwrap();
        assert!(dist(led_px, (led(4).0, 106.0)) < 1e-3, "{led_px:?}");
        // Its lights moved with it: in frame 5, 10 px on from there.
        let next = (turned(offsets[0]).0 + 10.0, turned(offsets[0]).1);
        assert!(b.explains(next, 20.0, 5, step, [next].into_iter()));
        // One light alone moves nothing, however well it matches.
        let mut b = trained();
        let one = [turned(offsets[0])];
        assert_eq!(b.follow(4, step, 50.0, one.into_iter()), None);
        // Two that disagree (one of them matched the LED itself) move nothing.
        let mut b = trained();
        let disagree = [turned(offsets[0]), (led(4).0, 106.0)];
        assert_eq!(b.follow(4, step, 50.0, disagree.into_iter()), None);
    }
    #[test]
    fn a_row_of_lamps_spaced_like_the_led_s_step_does_not_move_with_it() {
        let mut b = Body::default();
        let led = |i: u64| (100.0 + 10.0 * i as f32, 100.0);
        // Lamps every 10 px along the LED's motion: each is where the one behind it would be
        // carried, but each also stands where it stood.
        let lamps: Vec<(f32, f32)> = (0..6).map(|k| (300.0 + 10.0 * k as f32, 150.0)).collect();
        for i in 0..8 {
            seen(&mut b, i, led(i), &lamps);
        }
        assert!(!b.has_lights());
    }

    #[test]
    fn specks_beside_the_led_never_crowd_out_a_light_of_its_body() {
        let mut b = Body::default();
        let led = |i: u64| (100.0 + 10.0 * i as f32, 100.0);
        let other = |i: u64| (led(i).0 + 20.0, 100.0);
        // A window broken into more specks than the table holds (in a column, across the
        // LED's motion), seen before the light.
        let specks: Vec<(f32, f32)> = (0..2 * MAX_LIGHTS)
            .map(|k| (400.0, 200.0 + 5.0 * k as f32))
            .collect();
        for i in 0..6 {
            let mut seen_now = specks.clone();
            seen_now.push(other(i));
            seen(&mut b, i, led(i), &seen_now);
        }
        assert!(b.explains(other(6), 20.0, 6, (10.0, 0.0), [other(6)].into_iter()));
    }
}
