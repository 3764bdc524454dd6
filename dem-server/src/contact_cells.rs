//! The soft-sphere engine's contact search on a dense cell grid over the domain. The
//! spheres are walked in the order of their cell's index, `x + n_x (y + n_y z)`, so the
//! spheres of one cell are a run of that order and the three cells of a row along x
//! (x − 1, x, x + 1) one run as well: a sphere's candidates are the spheres of at most
//! nine such runs (eighteen where a periodic x wraps), read in place, with nothing to
//! hash and nothing to deduplicate. [`CellHash`](couplet_protocol::cell_hash::CellHash)
//! takes over where the domain holds too many cells for the spheres (a metre box of
//! millimetre grains): see [`ContactCells::new`].

use std::ops::Range;

/// Cells of at least `cell` on each axis over the domain; along a periodic axis they
/// divide the period exactly and their index wraps.
#[derive(Debug, Clone)]
pub struct ContactCells {
    min: [f64; 3],
    inv_cell: [f64; 3],
    n: [i64; 3],
    periodic: [bool; 3],
    /// Traversal position of the first sphere of each cell (cells + 1 entries, the last
    /// the sphere count), from [`ContactCells::fill`].
    start: Vec<u32>,
}

/// Most cells per sphere the dense grid takes: its `start` array is written every step,
/// 16 entries a sphere at this bound, about as many as a sphere's search reads in a
/// dense packing (a bound chosen so, not measured). Robinson's RTI column has about 6 a
/// sphere (15 300 grains, 41 × 57 × 41 cells).
const MAX_CELLS_PER_SPHERE: usize = 16;

/// Cells the dense grid takes whatever the sphere count (a few spheres in a small box).
const MIN_CELLS: usize = 1 << 16;

impl ContactCells {
    /// The grid of cell edge at least `cell` over `[min, max]`, or `None` when it would
    /// hold more than `MAX_CELLS_PER_SPHERE` cells per sphere (and more than
    /// `MIN_CELLS`): the hashed grid is then cheaper. `period[k]` is the length of a
    /// periodic axis k (which starts at `min[k]`).
    pub fn new(
        min: [f64; 3],
        max: [f64; 3],
        cell: f64,
        period: [Option<f64>; 3],
        spheres: usize,
    ) -> Option<ContactCells> {
        let mut n = [1i64; 3];
        let mut inv_cell = [0.0; 3];
        for k in 0..3 {
            let length = period[k].unwrap_or(max[k] - min[k]);
            let cells = (length / cell).floor().max(1.0);
            if !(cells.is_finite() && cells < 1e7) {
                return None;
            }
            n[k] = cells as i64;
            inv_cell[k] = cells / length;
        }
        // In f64: three axes of up to 1e7 cells overflow any integer product.
        let total: f64 = n.iter().map(|&c| c as f64).product();
        if total > (MAX_CELLS_PER_SPHERE * spheres).max(MIN_CELLS) as f64 {
            return None;
        }
        Some(ContactCells {
            min,
            inv_cell,
            n,
            periodic: period.map(|p| p.is_some()),
            start: Vec::new(),
        })
    }

    /// The cell of `p` along each axis: wrapped along a periodic axis, else clamped to
    /// the grid (a sphere a little outside the domain is in the edge cell, whose
    /// neighbours still hold every sphere within one cell edge of it).
    fn coords(&self, p: [f64; 3]) -> [i64; 3] {
        std::array::from_fn(|k| {
            let c = ((p[k] - self.min[k]) * self.inv_cell[k]).floor() as i64;
            if self.periodic[k] {
                c.rem_euclid(self.n[k])
            } else {
                c.clamp(0, self.n[k] - 1)
            }
        })
    }

    fn index(&self, c: [i64; 3]) -> usize {
        (c[0] + self.n[0] * (c[1] + self.n[1] * c[2])) as usize
    }

    /// The key to walk `p` by: its cell's index.
    pub fn key(&self, p: [f64; 3]) -> u64 {
        self.index(self.coords(p)) as u64
    }

    /// Where each cell's spheres start in the traversal order, from the walk's keys in
    /// order ([`ContactCells::key`] of each sphere, ascending).
    pub fn fill(&mut self, sorted_keys: impl Iterator<Item = u64>) {
        let cells = self.n.iter().product::<i64>() as usize;
        self.start.clear();
        self.start.reserve(cells + 1);
        let mut count = 0u32;
        for key in sorted_keys {
            while self.start.len() <= key as usize {
                self.start.push(count);
            }
            count += 1;
        }
        self.start.resize(cells + 1, count);
    }

    /// The cells a sphere in cell `c` meets along axis `k`, ascending: c − 1, c, c + 1,
    /// wrapped or cut at the grid's faces, each once (a periodic axis of one or two
    /// cells has only those).
    fn near(&self, k: usize, c: i64) -> ([i64; 3], usize) {
        let n = self.n[k];
        if !self.periodic[k] {
            let (lo, hi) = ((c - 1).max(0), (c + 1).min(n - 1));
            return ([lo, lo + 1, lo + 2], (hi - lo + 1) as usize);
        }
        match n {
            1 => ([0; 3], 1),
            2 => ([0, 1, 0], 2),
            _ if c == 0 => ([0, 1, n - 1], 3),
            _ if c == n - 1 => ([0, n - 2, n - 1], 3),
            _ => ([c - 1, c, c + 1], 3),
        }
    }

    /// The traversal positions of every sphere in the 27 cells around `p`, each once, as
    /// runs: along x the cells of a row are merged where they are consecutive.
    pub fn runs(&self, p: [f64; 3]) -> ([Range<u32>; 18], usize) {
        let c = self.coords(p);
        let (xs, mx) = self.near(0, c[0]);
        let (ys, my) = self.near(1, c[1]);
        let (zs, mz) = self.near(2, c[2]);
        let mut out: [Range<u32>; 18] = std::array::from_fn(|_| 0..0);
        let mut m = 0;
        for &z in &zs[..mz] {
            for &y in &ys[..my] {
                let mut i = 0;
                while i < mx {
                    let mut j = i;
                    while j + 1 < mx && xs[j + 1] == xs[j] + 1 {
                        j += 1;
                    }
                    let first = self.index([xs[i], y, z]);
                    let last = self.index([xs[j], y, z]);
                    let run = self.start[first]..self.start[last + 1];
                    if !run.is_empty() {
                        out[m] = run;
                        m += 1;
                    }
                    i = j + 1;
                }
            }
        }
        (out, m)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use couplet_protocol::vec3::{norm, sub};

    fn uniform(state: &mut u64, lo: f64, hi: f64) -> f64 {
        *state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        lo + (hi - lo) * ((*state >> 11) as f64 / (1u64 << 53) as f64)
    }

    /// Every pair closer than the cell edge is found from both of its spheres, and no
    /// sphere twice, through periodic faces too and with a periodic axis of two cells
    /// (where x − 1 and x + 1 are one cell). Reference: all pairs by brute force, with
    /// the minimum image along the periodic axes.
    #[test]
    fn runs_hold_every_sphere_within_a_cell_once() {
        for (period, label) in [
            ([None; 3], "bounded"),
            ([Some(0.04), None, Some(0.04)], "periodic x and z"),
            ([Some(0.009), None, None], "periodic x of two cells"),
        ] {
            let mut rng = 5;
            let cell = 4e-3;
            let (min, max) = ([-0.02; 3], [0.02; 3]);
            let extent: [f64; 3] = std::array::from_fn(|k| period[k].unwrap_or(0.04));
            let x: Vec<[f64; 3]> = (0..1500)
                .map(|_| std::array::from_fn(|k| uniform(&mut rng, min[k], min[k] + extent[k])))
                .collect();
            let mut grid = ContactCells::new(min, max, cell, period, x.len()).unwrap();
            let mut keyed: Vec<(u64, usize)> = x
                .iter()
                .enumerate()
                .map(|(i, p)| (grid.key(*p), i))
                .collect();
            keyed.sort();
            grid.fill(keyed.iter().map(|k| k.0));
            let mut pairs = 0;
            for (s, &(_, i)) in keyed.iter().enumerate() {
                let (runs, m) = grid.runs(x[i]);
                let mut found: Vec<usize> = runs[..m]
                    .iter()
                    .flat_map(|r| r.clone())
                    .map(|t| keyed[t as usize].1)
                    .collect();
                let listed = found.len();
                found.sort_unstable();
                found.dedup();
                assert_eq!(
                    found.len(),
                    listed,
                    "{label}: sphere {s} listed a sphere twice"
                );
                for (j, q) in x.iter().enumerate() {
                    let mut d = sub(x[i], *q);
                    for k in 0..3 {
                        if let Some(l) = period[k] {
                            d[k] -= l * (d[k] / l).round();
                        }
                    }
                    if norm(d) < cell {
                        pairs += 1;
                        assert!(
                            found.binary_search(&j).is_ok(),
                            "{label}: {j} is {} from {i} and not listed",
                            norm(d)
                        );
                    }
                }
            }
            assert!(pairs > 3000, "{label}: only {pairs} close pairs");
        }
    }

    /// A box of more cells than `MAX_CELLS_PER_SPHERE` a sphere (and `MIN_CELLS`) is
    /// left to the hashed grid, also where the cell count overflows a 64-bit integer.
    #[test]
    fn a_sparse_box_is_left_to_the_hash() {
        let (min, max) = ([0.0; 3], [1.0; 3]);
        let dense = |cell: f64, spheres: usize| {
            ContactCells::new(min, max, cell, [None; 3], spheres).is_some()
        };
        assert!(!dense(1e-3, 1000), "1e9 cells, 1e6 a sphere");
        assert!(!dense(1e-2, 1000), "1e6 cells, 1000 a sphere");
        assert!(dense(1e-2, 100_000), "1e6 cells, 10 a sphere");
        assert!(dense(1e-1, 10), "1000 cells, under MIN_CELLS");
        // 2^22 cells an axis: their product, 2^66, wrapped to 0 in a u64.
        let side = f64::from(1u32 << 22);
        assert!(ContactCells::new(min, [side; 3], 1.0, [None; 3], 1000).is_none());
    }
}
