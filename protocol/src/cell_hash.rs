//! A cell grid hashed into buckets, for finding everything within one cell edge of a
//! point: the soft-sphere engine's contact candidates (cells of the largest diameter)
//! and the fluid server's grains within a kernel support (porosity, Robinson eq. 9).
//! Here because both servers use it and both depend on this crate.

/// Cells of at least a given edge hashed into a table of `2^b ≥ 2N` buckets, built by a
/// counting sort: the domain may hold many more cells than points (a metre box of
/// millimetre grains), so cells are not stored densely. A hash collision only adds
/// candidates that the caller's distance test rejects. Along a periodic axis the cells
/// divide the period exactly and their index wraps, so that points at opposite faces
/// are neighbours.
#[derive(Debug, Default)]
pub struct CellHash {
    origin: [f64; 3],
    /// Inverse cell edge per axis.
    inv_cell: [f64; 3],
    /// Cells along each periodic axis (cell keys wrap modulo it).
    wrap: [Option<i64>; 3],
    mask: u64,
    /// Bucket start offsets (buckets + 1) and point indices sorted by bucket.
    start: Vec<u32>,
    entries: Vec<u32>,
    bucket_of: Vec<u64>,
}

/// The hash of one axis's cell index, combined across axes by xor.
const AXIS_HASH: [u64; 3] = [
    0x9E37_79B9_7F4A_7C15,
    0xC2B2_AE3D_27D4_EB4F,
    0x1656_67B1_9E37_79F9,
];

impl CellHash {
    fn key(&self, x: [f64; 3]) -> [i64; 3] {
        [0, 1, 2].map(|k| ((x[k] - self.origin[k]) * self.inv_cell[k]).floor() as i64)
    }

    /// One axis's part of a bucket's hash, for cell index `c` (wrapped on a periodic axis).
    fn axis_part(&self, k: usize, c: i64) -> u64 {
        let c = self.wrap[k].map_or(c, |n| c.rem_euclid(n));
        (c as u64).wrapping_mul(AXIS_HASH[k])
    }

    fn mix(&self, h: u64) -> u64 {
        (h ^ (h >> 29)) & self.mask
    }

    /// Bins `x` in cells of at least `cell` on every axis. Periodic axes (`Some(period)`)
    /// start at `origin`.
    pub fn build(&mut self, x: &[[f64; 3]], cell: f64, origin: [f64; 3], period: [Option<f64>; 3]) {
        self.origin = origin;
        for k in 0..3 {
            (self.inv_cell[k], self.wrap[k]) = match period[k] {
                Some(l) => {
                    let n = (l / cell).floor().max(1.0);
                    (n / l, Some(n as i64))
                }
                None => (1.0 / cell, None),
            };
        }
        let buckets = (2 * x.len()).next_power_of_two().max(2);
        self.mask = buckets as u64 - 1;
        let mut bucket_of = std::mem::take(&mut self.bucket_of);
        bucket_of.clear();
        bucket_of.extend(x.iter().map(|p| {
            let c = self.key(*p);
            self.mix((0..3).fold(0, |h, k| h ^ self.axis_part(k, c[k])))
        }));
        self.bucket_of = bucket_of;
        self.start.clear();
        self.start.resize(buckets + 1, 0);
        for b in &self.bucket_of {
            self.start[*b as usize + 1] += 1;
        }
        for k in 0..buckets {
            self.start[k + 1] += self.start[k];
        }
        self.entries.resize(x.len(), 0);
        let mut fill = self.start.clone();
        for (i, b) in self.bucket_of.iter().enumerate() {
            self.entries[fill[*b as usize] as usize] = i as u32;
            fill[*b as usize] += 1;
        }
    }

    /// The buckets of the 27 cells around `p`, each once (a short period or a
    /// collision maps two cells to one bucket), in (dx, dy, dz) order: the first
    /// `.1` entries. Each axis's three cells are wrapped and hashed once, not once per
    /// cell (the 81 wraps and multiplications were most of a contact search where
    /// grains seldom touch).
    pub fn near_buckets(&self, p: [f64; 3]) -> ([u64; 27], usize) {
        let c = self.key(p);
        let part = |k: usize| [-1, 0, 1].map(|d| self.axis_part(k, c[k] + d));
        let (hx, hy, hz) = (part(0), part(1), part(2));
        let mut seen = [u64::MAX; 27];
        let mut m = 0;
        for x in hx {
            for y in hy {
                for z in hz {
                    let b = self.mix(x ^ y ^ z);
                    if !seen[..m].contains(&b) {
                        seen[m] = b;
                        m += 1;
                    }
                }
            }
        }
        (seen, m)
    }

    /// The points binned in bucket `b`.
    pub fn bucket(&self, b: u64) -> &[u32] {
        let b = b as usize;
        &self.entries[self.start[b] as usize..self.start[b + 1] as usize]
    }

    /// Every point in the 27 cells around `p` (and whatever shares their buckets), each
    /// once. Read in place: copying each bucket out (27 small copies a sphere) took a
    /// sixth of a soft-sphere step at 100 k spheres.
    pub fn candidates(&self, p: [f64; 3]) -> impl Iterator<Item = u32> + '_ {
        let (seen, m) = self.near_buckets(p);
        (0..m).flat_map(move |q| self.bucket(seen[q]).iter().copied())
    }
}
