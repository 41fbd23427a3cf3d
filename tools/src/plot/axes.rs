//! Axis ranges with round tick marks, and the map from data to canvas pixels.

/// Aim for about this many tick marks along an axis.
const TARGET_TICKS: f64 = 6.0;
/// More ticks than this only happen on degenerate ranges (values near the limits of `f64`,
/// where the step is lost in rounding); such an axis gets none.
const MAX_TICKS: i64 = 100;

/// A data range shown along one axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Range {
    pub min: f64,
    pub max: f64,
}

impl Range {
    /// The smallest range holding all `values`; `None` when there are none. A single value
    /// gets a range of one unit around it, so it can still be placed on an axis.
    pub fn of(values: impl IntoIterator<Item = f64>) -> Option<Self> {
        let mut range: Option<Range> = None;
        for v in values.into_iter().filter(|v| v.is_finite()) {
            range = Some(match range {
                None => Range { min: v, max: v },
                Some(r) => Range {
                    min: r.min.min(v),
                    max: r.max.max(v),
                },
            });
        }
        range.map(|r| {
            if r.max - r.min > 0.0 {
                r
            } else {
                Range {
                    min: r.min - 0.5,
                    max: r.max + 0.5,
                }
            }
        })
    }

    pub fn span(&self) -> f64 {
        self.max - self.min
    }

    /// The range grown on both sides to `span` (at least its own), keeping its centre.
    pub fn widened_to(&self, span: f64) -> Self {
        let centre = (self.min + self.max) / 2.0;
        let half = span.max(self.span()) / 2.0;
        Range {
            min: centre - half,
            max: centre + half,
        }
    }

    /// The range extended to whole multiples of its tick step.
    pub fn rounded_out(&self) -> Self {
        let step = tick_step(self.span());
        Range {
            min: (self.min / step).floor() * step,
            max: (self.max / step).ceil() * step,
        }
    }

    /// Tick values inside the range, at a round step (1, 2 or 5 times a power of ten).
    pub fn ticks(&self) -> Vec<f64> {
        let step = tick_step(self.span());
        let first = (self.min / step).ceil() as i64;
        let last = (self.max / step).floor() as i64;
        match last.checked_sub(first) {
            Some(0..=MAX_TICKS) => (first..=last).map(|k| k as f64 * step).collect(),
            _ => Vec::new(),
        }
    }

    /// Decimals needed to print this range's ticks without repeating a label.
    pub fn tick_decimals(&self) -> usize {
        let step = tick_step(self.span());
        (-step.log10().floor()).max(0.0) as usize
    }
}

/// A round step giving about [`TARGET_TICKS`] ticks over `span`.
fn tick_step(span: f64) -> f64 {
    let raw = (span / TARGET_TICKS).max(f64::MIN_POSITIVE);
    let magnitude = 10f64.powf(raw.log10().floor());
    let mantissa = raw / magnitude;
    let nice = if mantissa <= 1.0 {
        1.0
    } else if mantissa <= 2.0 {
        2.0
    } else if mantissa <= 5.0 {
        5.0
    } else {
        10.0
    };
    nice * magnitude
}

/// A linear map from a data range onto a pixel interval; `flip` puts `range.min` at the far
/// end (for y axes that grow upwards on a canvas whose rows grow downwards).
#[derive(Debug, Clone, Copy)]
pub struct Scale {
    pub range: Range,
    pub start_px: f64,
    pub end_px: f64,
    pub flip: bool,
}

impl Scale {
    /// The canvas coordinate of `value`, rounded to a pixel.
    pub fn px(&self, value: f64) -> i64 {
        let mut fraction = (value - self.range.min) / self.range.span();
        if self.flip {
            fraction = 1.0 - fraction;
        }
        (self.start_px + fraction * (self.end_px - self.start_px)).round() as i64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_fall_on_round_steps_inside_the_range() {
        let r = Range {
            min: 3.2,
            max: 97.0,
        };
        assert_eq!(r.ticks(), vec![20.0, 40.0, 60.0, 80.0]);
        let small = Range {
            min: -0.013,
            max: 0.041,
        };
        assert_eq!(small.ticks().len(), 6); // -0.01 .. 0.04
        assert_eq!(small.tick_decimals(), 2);
        assert_eq!(
            r.rounded_out(),
            Range {
                min: 0.0,
                max: 100.0
            }
        );
    }

    #[test]
    fn a_single_value_gets_a_usable_range() {
        let r = Range::of([5.0, 5.0]).unwrap();
        assert!(r.min < 5.0 && r.max > 5.0);
        assert_eq!(Range::of(std::iter::empty()), None);
        assert_eq!(Range::of([f64::NAN]), None);
    }

    #[test]
    fn scales_map_ends_and_flip() {
        let range = Range {
            min: 0.0,
            max: 10.0,
        };
        let down = Scale {
            range,
            start_px: 100.0,
            end_px: 200.0,
            flip: false,
        };
        let up = Scale { flip: true, ..down };
        assert_eq!((down.px(0.0), down.px(10.0), down.px(2.5)), (100, 200, 125));
        assert_eq!((up.px(0.0), up.px(10.0)), (200, 100));
    }
}
