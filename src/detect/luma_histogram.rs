//! A histogram of luma levels kept on the stack: a quantile of a few hundred pixels' luma
//! without sorting or allocating, on the per-frame path (the fit's flat floor start, the
//! learned floor around a streak), and the mean of a row's darker pixels (`glint row-time`).

/// Counts of luma levels 0–255.
pub struct LumaHistogram {
    bins: [u16; 256],
    count: usize,
}

impl LumaHistogram {
    /// An empty histogram.
    pub fn new() -> Self {
        LumaHistogram {
            bins: [0; 256],
            count: 0,
        }
    }

    /// Counts `luma` at its nearest level; a value outside 0–255 is not counted.
    pub fn add(&mut self, luma: f32) {
        let level = luma.round();
        if !(0.0..=255.0).contains(&level) {
            return;
        }
        if let Some(bin) = self.bins.get_mut(level as usize) {
            *bin = bin.saturating_add(1);
            self.count += 1;
        }
    }

    /// The values counted.
    pub fn count(&self) -> usize {
        self.count
    }

    /// The lowest level with more than `rank` values at or below it (`rank` 0 is the least
    /// value); `None` with no more than `rank` values counted.
    pub fn level_above(&self, rank: usize) -> Option<f32> {
        let mut seen = 0usize;
        for (level, &n) in self.bins.iter().enumerate() {
            seen += usize::from(n);
            if seen > rank {
                return Some(level as f32);
            }
        }
        None
    }

    /// The mean of the `n` least values counted (of all of them when fewer); `None` when
    /// nothing is counted or `n` is 0.
    pub fn mean_of_lowest(&self, n: usize) -> Option<f32> {
        let n = n.min(self.count);
        if n == 0 {
            return None;
        }
        let (mut left, mut sum) = (n, 0u64);
        for (level, &count) in self.bins.iter().enumerate() {
            let taken = usize::from(count).min(left);
            sum += (taken * level) as u64;
            left -= taken;
            if left == 0 {
                break;
            }
        }
        Some(sum as f32 / n as f32)
    }

    /// The median: the lower of the two middle values of an even count; `None` when empty.
    pub fn median(&self) -> Option<f32> {
        self.level_above(self.count.checked_sub(1)? / 2)
    }
}

impl Default for LumaHistogram {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Ranks read the sorted values, rounded to levels; values out of range are not counted.
    #[test]
    fn a_rank_is_the_sorted_values_level() {
        let values = [7.0f32, 3.2, 250.0, 3.0, 99.6, 12.0, -4.0, 300.0];
        let mut h = LumaHistogram::new();
        values.iter().for_each(|&v| h.add(v));
        assert_eq!(h.count(), 6);
        let want = [3.0, 3.0, 7.0, 12.0, 100.0, 250.0];
        for (rank, &level) in want.iter().enumerate() {
            assert_eq!(h.level_above(rank), Some(level), "rank {rank}");
        }
        assert_eq!(h.level_above(6), None);
        assert_eq!(LumaHistogram::new().level_above(0), None);
        // Of six, the lower middle value; of seven, the middle one.
        assert_eq!(h.median(), Some(7.0));
        h.add(11.6);
        assert_eq!(h.median(), Some(12.0));
        assert_eq!(LumaHistogram::new().median(), None);
        // 3, 3, 7, 12, 12, 100, 250: the lowest four average 6.25.
        assert_eq!(h.mean_of_lowest(4), Some(6.25));
        assert_eq!(h.mean_of_lowest(100), Some(387.0 / 7.0));
        assert_eq!(h.mean_of_lowest(0), None);
        assert_eq!(LumaHistogram::new().mean_of_lowest(3), None);
    }
}
