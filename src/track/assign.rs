//! Optimal assignment of tracks to candidate blobs: the Hungarian method (Kuhn–Munkres with
//! row and column potentials, O(rows² · columns)), on a cost matrix whose size is bounded at
//! compile time, so that it runs without allocating.
//!
//! Every track may also stay unassigned, at a cost of its gate radius: one "miss" column per
//! track is appended to the candidates, so a solution always exists and a track takes a
//! candidate only when that is no dearer than missing. A pair outside the gate is forbidden.
//! Written here because the crates that solve this (`pathfinding`, `hungarian`) allocate
//! their matrices and results on every call.

use crate::detect::blobs::MAX_BLOBS;

use super::multi::MAX_ROBOTS;

/// Columns: every candidate, then one miss column per track.
const MAX_COLUMNS: usize = MAX_BLOBS + MAX_ROBOTS;

/// The cost of a forbidden pair: far above any sum of allowed costs (gates are hundreds of
/// pixels at most, and at most [`MAX_ROBOTS`] are summed).
const FORBIDDEN: f32 = 1.0e9;

/// The solver's matrix and work arrays, sized once.
#[derive(Debug)]
pub struct Assignment {
    cost: [[f32; MAX_COLUMNS]; MAX_ROBOTS],
    /// Row potentials, 1-based (index 0 unused).
    row_potential: [f64; MAX_ROBOTS + 1],
    /// Column potentials, 1-based, index 0 the virtual start column.
    column_potential: [f64; MAX_COLUMNS + 1],
    /// The row (1-based, 0: none) each column is matched to.
    matched_row: [usize; MAX_COLUMNS + 1],
    way: [usize; MAX_COLUMNS + 1],
    slack: [f64; MAX_COLUMNS + 1],
    used: [bool; MAX_COLUMNS + 1],
    /// Each row's column: a candidate index below `candidates`, else a miss.
    row_column: [usize; MAX_ROBOTS],
    rows: usize,
    candidates: usize,
}

impl Default for Assignment {
    fn default() -> Self {
        Assignment {
            cost: [[FORBIDDEN; MAX_COLUMNS]; MAX_ROBOTS],
            row_potential: [0.0; MAX_ROBOTS + 1],
            column_potential: [0.0; MAX_COLUMNS + 1],
            matched_row: [0; MAX_COLUMNS + 1],
            way: [0; MAX_COLUMNS + 1],
            slack: [0.0; MAX_COLUMNS + 1],
            used: [false; MAX_COLUMNS + 1],
            row_column: [0; MAX_ROBOTS],
            rows: 0,
            candidates: 0,
        }
    }
}

impl Assignment {
    /// Solves for `rows` tracks (at most [`MAX_ROBOTS`]) and `candidates` blobs (at most
    /// [`MAX_BLOBS`]; more are cut): `cost(row, candidate)` is the pair's cost when allowed,
    /// `miss(row)` the cost of the row taking nothing. Costs that are not finite forbid.
    pub fn solve(
        &mut self,
        rows: usize,
        candidates: usize,
        cost: impl Fn(usize, usize) -> Option<f32>,
        miss: impl Fn(usize) -> f32,
    ) {
        let rows = rows.min(MAX_ROBOTS);
        let candidates = candidates.min(MAX_BLOBS);
        self.rows = rows;
        self.candidates = candidates;
        let columns = candidates + rows;
        let allowed = |c: f32| if c.is_finite() { c } else { FORBIDDEN };
        for (row, line) in self.cost.iter_mut().enumerate().take(rows) {
            for (column, c) in line.iter_mut().enumerate().take(columns) {
                *c = if column < candidates {
                    cost(row, column).map_or(FORBIDDEN, allowed)
                } else {
                    allowed(miss(row))
                };
            }
        }
        self.hungarian(rows, columns);
        for column in 1..=columns {
            let row = self.matched_row[column];
            if row > 0 {
                self.row_column[row - 1] = column - 1;
            }
        }
    }

    /// The candidate row `row` took in the last solution, if any.
    pub fn candidate_of(&self, row: usize) -> Option<usize> {
        if row >= self.rows {
            return None;
        }
        let column = self.row_column[row];
        let allowed = self.cost[row][column] < FORBIDDEN;
        (column < self.candidates && allowed).then_some(column)
    }

    /// The e-maxx formulation: rows are added one at a time, each by a shortest augmenting
    /// path over reduced costs, keeping the potentials feasible.
    fn hungarian(&mut self, rows: usize, columns: usize) {
        self.row_potential[..=rows].fill(0.0);
        self.column_potential[..=columns].fill(0.0);
        self.matched_row[..=columns].fill(0);
        self.way[..=columns].fill(0);
        for row in 1..=rows {
            self.matched_row[0] = row;
            let mut column0 = 0;
            self.slack[..=columns].fill(f64::INFINITY);
            self.used[..=columns].fill(false);
            loop {
                self.used[column0] = true;
                let row0 = self.matched_row[column0];
                let mut delta = f64::INFINITY;
                let mut column1 = 0;
                for column in 1..=columns {
                    if self.used[column] {
                        continue;
                    }
                    let reduced = f64::from(self.cost[row0 - 1][column - 1])
                        - self.row_potential[row0]
                        - self.column_potential[column];
                    if reduced < self.slack[column] {
                        self.slack[column] = reduced;
                        self.way[column] = column0;
                    }
                    if self.slack[column] < delta {
                        delta = self.slack[column];
                        column1 = column;
                    }
                }
                for column in 0..=columns {
                    if self.used[column] {
                        self.row_potential[self.matched_row[column]] += delta;
                        self.column_potential[column] -= delta;
                    } else {
                        self.slack[column] -= delta;
                    }
                }
                column0 = column1;
                if self.matched_row[column0] == 0 {
                    break;
                }
            }
            loop {
                let column1 = self.way[column0];
                self.matched_row[column0] = self.matched_row[column1];
                column0 = column1;
                if column0 == 0 {
                    break;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn solve(costs: &[&[Option<f32>]], miss: f32) -> Vec<Option<usize>> {
        let mut a = Assignment::default();
        let candidates = costs.first().map_or(0, |r| r.len());
        a.solve(costs.len(), candidates, |r, c| costs[r][c], |_| miss);
        (0..costs.len()).map(|r| a.candidate_of(r)).collect()
    }

    #[test]
    fn the_global_optimum_beats_the_greedy_choice() {
        // Greedy would give row 0 its nearest (candidate 0, cost 1) and leave row 1 with 10;
        // the optimum pays 2 + 2.
        let got = solve(&[&[Some(1.0), Some(2.0)], &[Some(2.0), Some(10.0)]], 50.0);
        assert_eq!(got, [Some(1), Some(0)]);
    }

    #[test]
    fn forbidden_pairs_and_misses() {
        // Row 1 may take only candidate 0, which row 0 wants too: row 0 takes candidate 1.
        let got = solve(&[&[Some(1.0), Some(3.0)], &[Some(1.0), None]], 50.0);
        assert_eq!(got, [Some(1), Some(0)]);
        // Nothing allowed: both miss.
        assert_eq!(solve(&[&[None], &[None]], 50.0), [None, None]);
        // More rows than candidates: the nearer row takes it.
        assert_eq!(solve(&[&[Some(5.0)], &[Some(1.0)]], 50.0), [None, Some(0)]);
        // Missing is cheaper than a far candidate.
        assert_eq!(solve(&[&[Some(60.0)]], 50.0), [None]);
        // No candidates at all.
        assert_eq!(solve(&[&[], &[]], 50.0), [None, None]);
    }

    #[test]
    fn agrees_with_brute_force_on_small_random_matrices() {
        // A small xorshift, seeded: reproducible without a dependency.
        let mut state = 0x2545_f491_u32;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state
        };
        for _ in 0..300 {
            let rows = 1 + (next() % 4) as usize;
            let cols = (next() % 5) as usize;
            let m: Vec<Vec<Option<f32>>> = (0..rows)
                .map(|_| {
                    (0..cols)
                        .map(|_| (next() % 4 != 0).then(|| (next() % 100) as f32))
                        .collect()
                })
                .collect();
            let miss = 60.0;
            let refs: Vec<&[Option<f32>]> = m.iter().map(Vec::as_slice).collect();
            let got = solve(&refs, miss);
            let total = |a: &[Option<usize>]| -> f32 {
                a.iter()
                    .enumerate()
                    .map(|(r, c)| c.map_or(miss, |c| m[r][c].unwrap()))
                    .sum()
            };
            // Every assignment of rows to distinct allowed candidates or a miss.
            fn all(
                m: &[Vec<Option<f32>>],
                row: usize,
                taken: &mut Vec<bool>,
                cur: &mut Vec<Option<usize>>,
                out: &mut Vec<Vec<Option<usize>>>,
            ) {
                if row == m.len() {
                    out.push(cur.clone());
                    return;
                }
                cur.push(None);
                all(m, row + 1, taken, cur, out);
                cur.pop();
                for c in 0..taken.len() {
                    if !taken[c] && m[row][c].is_some() {
                        taken[c] = true;
                        cur.push(Some(c));
                        all(m, row + 1, taken, cur, out);
                        cur.pop();
                        taken[c] = false;
                    }
                }
            }
            let mut every = Vec::new();
            all(&m, 0, &mut vec![false; cols], &mut Vec::new(), &mut every);
            let best = every.iter().map(|a| total(a)).fold(f32::INFINITY, f32::min);
            let used: Vec<usize> = got.iter().flatten().copied().collect();
            let mut dedup = used.clone();
            dedup.sort_unstable();
            dedup.dedup();
            assert_eq!(used.len(), dedup.len(), "a candidate taken twice: {got:?}");
            assert!((total(&got) - best).abs() < 1e-3, "{m:?}: {got:?}");
        }
    }
}
