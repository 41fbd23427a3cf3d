//! YUYV 4:2:2 to RGB with the BT.601 matrix, in full or studio range.
//!
//! Webcams deliver either full-range video (Y, U, V all 0..=255, as JPEG does) or studio-range
//! video (Y from 16 for black to 235 for white, chroma 16..=240). Shown with the wrong
//! range, a studio-range frame looks washed out and a full-range one crushed; the LED, which
//! is what the overlay is about, is white either way only when the range is right.

use glint::frame::{Frame, YUYV_BYTES_PER_PIXEL};

/// Bytes of one `Y0 U Y1 V` group: two pixels.
const BYTES_PER_PAIR: usize = 2 * YUYV_BYTES_PER_PIXEL;

/// How a camera's 8-bit YUV codes map to light.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum YuvRange {
    /// Y, U and V span 0..=255 (JPEG/JFIF).
    Full,
    /// Y spans 16..=235 and U, V 16..=240 (ITU-R BT.601 "studio swing"); codes beyond them
    /// (super-white, which saturated LEDs often reach) clip to white.
    Studio,
}

/// Neutral chroma.
const CHROMA_ZERO: f32 = 128.0;

/// Studio-range black and the luma and chroma spans of studio range.
const STUDIO_BLACK: f32 = 16.0;
const STUDIO_LUMA_SPAN: f32 = 219.0;
const STUDIO_CHROMA_SPAN: f32 = 224.0;
const FULL_SPAN: f32 = 255.0;

/// BT.601's chroma-to-RGB coefficients for unit-span chroma (Kr = 0.299, Kb = 0.114):
/// R = Y + 2(1-Kr)·Cr, B = Y + 2(1-Kb)·Cb, G from the luma equation.
const CR_TO_R: f32 = 1.402;
const CB_TO_G: f32 = -0.344_136;
const CR_TO_G: f32 = -0.714_136;
const CB_TO_B: f32 = 1.772;

/// A frame whose brightest luma is above this cannot be studio range (even super-white LEDs
/// on studio-range webcams stay around 235–243).
const STUDIO_MAX_LUMA: u8 = 245;
/// A frame with luma below this cannot be studio range (black is 16; read noise dips a
/// little below it, not to single digits).
const STUDIO_MIN_LUMA: u8 = 8;

impl YuvRange {
    /// Guesses the range from the frame's own luma: studio range keeps away from both ends
    /// of the byte. A full-range frame with neither deep blacks nor a saturated pixel is
    /// guessed as studio and then shown with a little too much contrast, which is harmless
    /// in a viewer; pass the range explicitly when it is known.
    pub fn guess(frame: &Frame<'_>) -> YuvRange {
        let (mut min_luma, mut max_luma) = (u8::MAX, u8::MIN);
        for row in frame.rows() {
            for &y in row.iter().step_by(2) {
                min_luma = min_luma.min(y);
                max_luma = max_luma.max(y);
            }
        }
        if max_luma <= STUDIO_MAX_LUMA && min_luma >= STUDIO_MIN_LUMA {
            YuvRange::Studio
        } else {
            YuvRange::Full
        }
    }

    /// The RGB colour of one pixel with luma `y` and chroma `u` (Cb), `v` (Cr).
    pub fn to_rgb(self, y: u8, u: u8, v: u8) -> [u8; 3] {
        let (luma, cb, cr) = match self {
            YuvRange::Full => (
                f32::from(y),
                f32::from(u) - CHROMA_ZERO,
                f32::from(v) - CHROMA_ZERO,
            ),
            YuvRange::Studio => {
                let chroma_gain = FULL_SPAN / STUDIO_CHROMA_SPAN;
                (
                    (f32::from(y) - STUDIO_BLACK) * (FULL_SPAN / STUDIO_LUMA_SPAN),
                    (f32::from(u) - CHROMA_ZERO) * chroma_gain,
                    (f32::from(v) - CHROMA_ZERO) * chroma_gain,
                )
            }
        };
        [
            to_byte(luma + CR_TO_R * cr),
            to_byte(luma + CB_TO_G * cb + CR_TO_G * cr),
            to_byte(luma + CB_TO_B * cb),
        ]
    }
}

/// Rounds and clips a colour channel to a byte.
fn to_byte(value: f32) -> u8 {
    value.round().clamp(0.0, 255.0) as u8
}

/// The RGB colour of pixel `(x, y)` of a YUYV frame, or `None` outside it. The two pixels of
/// a `Y0 U Y1 V` group share their chroma.
pub fn pixel_rgb(frame: &Frame<'_>, range: YuvRange, x: usize, y: usize) -> Option<[u8; 3]> {
    if x >= frame.size().width() {
        return None;
    }
    let group_start = (x & !1) * YUYV_BYTES_PER_PIXEL;
    let group = frame
        .row(y)?
        .get(group_start..group_start + BYTES_PER_PAIR)?;
    let [y0, u, y1, v] = <[u8; BYTES_PER_PAIR]>::try_from(group).ok()?;
    let luma = if x & 1 == 0 { y0 } else { y1 };
    Some(range.to_rgb(luma, u, v))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glint::frame::FrameSize;

    #[test]
    fn studio_white_and_black_are_full_white_and_black() {
        assert_eq!(YuvRange::Studio.to_rgb(235, 128, 128), [255, 255, 255]);
        assert_eq!(YuvRange::Studio.to_rgb(16, 128, 128), [0, 0, 0]);
        // Super-white and sub-black clip instead of wrapping.
        assert_eq!(YuvRange::Studio.to_rgb(250, 128, 128), [255, 255, 255]);
        assert_eq!(YuvRange::Studio.to_rgb(4, 128, 128), [0, 0, 0]);
    }

    #[test]
    fn full_range_grey_is_its_luma() {
        assert_eq!(YuvRange::Full.to_rgb(255, 128, 128), [255, 255, 255]);
        assert_eq!(YuvRange::Full.to_rgb(0, 128, 128), [0, 0, 0]);
        assert_eq!(YuvRange::Full.to_rgb(100, 128, 128), [100, 100, 100]);
        // In studio range the same code is darker than mid-grey would be in full range.
        assert_eq!(YuvRange::Studio.to_rgb(126, 128, 128), [128, 128, 128]);
    }

    /// Primaries as BT.601 codes them (the standard's published 100 % colour-bar values).
    #[test]
    fn primaries_come_back() {
        // Studio range: red is (81, 90, 240), green (145, 54, 34), blue (41, 240, 110).
        assert_close(YuvRange::Studio.to_rgb(81, 90, 240), [255, 0, 0]);
        assert_close(YuvRange::Studio.to_rgb(145, 54, 34), [0, 255, 0]);
        assert_close(YuvRange::Studio.to_rgb(41, 240, 110), [0, 0, 255]);
        // Full range (JFIF): red is (76, 85, 255), blue (29, 255, 107).
        assert_close(YuvRange::Full.to_rgb(76, 85, 255), [255, 0, 0]);
        assert_close(YuvRange::Full.to_rgb(29, 255, 107), [0, 0, 255]);
    }

    /// Within the rounding of the 8-bit codes.
    fn assert_close(got: [u8; 3], want: [u8; 3]) {
        let close = got
            .iter()
            .zip(want)
            .all(|(&g, w)| (i16::from(g) - i16::from(w)).abs() <= 2);
        assert!(close, "got {got:?}, want {want:?}");
    }

    #[test]
    fn pixels_of_a_pair_share_chroma_but_keep_their_luma() {
        let size = FrameSize::new(4, 1).unwrap();
        // Pair 0: grey 50 and 200; pair 1: pure full-range red for both.
        let bytes = [50, 128, 200, 128, 76, 85, 76, 255];
        let frame = Frame::new_checked(&bytes, size, 8).unwrap();
        let rgb = |x| pixel_rgb(&frame, YuvRange::Full, x, 0);
        assert_eq!(rgb(0), Some([50, 50, 50]));
        assert_eq!(rgb(1), Some([200, 200, 200]));
        assert_eq!(rgb(2), rgb(3));
        assert_close(rgb(3).unwrap(), [255, 0, 0]);
        assert_eq!(rgb(4), None);
        assert_eq!(pixel_rgb(&frame, YuvRange::Full, 0, 1), None);
    }

    #[test]
    fn the_range_is_guessed_from_the_luma_extremes() {
        let size = FrameSize::new(2, 1).unwrap();
        let guess = |y0: u8, y1: u8| {
            let bytes = [y0, 128, y1, 128];
            YuvRange::guess(&Frame::new_checked(&bytes, size, 4).unwrap())
        };
        assert_eq!(guess(16, 235), YuvRange::Studio);
        assert_eq!(guess(20, 241), YuvRange::Studio);
        assert_eq!(guess(16, 255), YuvRange::Full);
        assert_eq!(guess(2, 200), YuvRange::Full);
    }
}
