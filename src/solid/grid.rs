//! Uniform search grid for neighbour queries in O(N): particles are binned into cubic cells of
//! side ≥ the search radius by a counting sort, and a query visits the 3^d surrounding cells.
//! Axes may be periodic (minimum-image displacements). Used for the MPS neighbour lists
//! (radius r_e, seed 2.20) and for contact detection (radius l₀, seed 2.23).

use glam::DVec3;

/// Periodic lengths per axis (None = not periodic).
pub type Periods = [Option<f64>; 3];

#[derive(Clone, Debug)]
pub struct SearchGrid {
    origin: DVec3,
    cell: f64,
    dims: [usize; 3],
    periods: Periods,
    /// Start of each cell's run in `order` (length cells + 1).
    start: Vec<u32>,
    /// Particle indices sorted by cell.
    order: Vec<u32>,
}

impl SearchGrid {
    /// Bins `x` into cells of side ≥ `radius`. Periodic axes span [0, period).
    pub fn build(x: &[DVec3], radius: f64, periods: Periods) -> Self {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for p in x {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        if x.is_empty() {
            lo = DVec3::ZERO;
            hi = DVec3::ZERO;
        }
        let mut origin = lo;
        let mut dims = [1usize; 3];
        let mut cell = radius;
        for a in 0..3 {
            if let Some(l) = periods[a] {
                origin[a] = 0.0;
                dims[a] = ((l / radius).floor() as usize).max(1);
            } else {
                dims[a] = (((hi[a] - lo[a]) / radius).floor() as usize + 1).max(1);
            }
        }
        // With periodic axes the cell side is the period / count (≥ radius).
        let side = |a: usize| match periods[a] {
            Some(l) => l / dims[a] as f64,
            None => radius,
        };
        // One common side keeps the query simple: take the largest.
        for a in 0..3 {
            cell = cell.max(side(a));
        }
        for a in 0..3 {
            if let Some(l) = periods[a] {
                dims[a] = ((l / cell).floor() as usize).max(1);
            } else {
                dims[a] = (((hi[a] - lo[a]) / cell).floor() as usize + 1).max(1);
            }
        }
        let mut g = Self { origin, cell, dims, periods, start: vec![0; dims[0] * dims[1] * dims[2] + 1], order: vec![0; x.len()] };
        let cells: Vec<usize> = x.iter().map(|p| g.cell_of(*p)).collect();
        for &c in &cells {
            g.start[c + 1] += 1;
        }
        for c in 0..g.start.len() - 1 {
            g.start[c + 1] += g.start[c];
        }
        let mut fill = g.start.clone();
        for (i, &c) in cells.iter().enumerate() {
            g.order[fill[c] as usize] = i as u32;
            fill[c] += 1;
        }
        g
    }

    fn coord(&self, p: DVec3, a: usize) -> usize {
        let mut t = (p[a] - self.origin[a]) / self.cell;
        if let Some(l) = self.periods[a] {
            t = (p[a] - l * (p[a] / l).floor()) / self.cell;
        }
        (t.floor().max(0.0) as usize).min(self.dims[a] - 1)
    }

    fn cell_of(&self, p: DVec3) -> usize {
        let (i, j, k) = (self.coord(p, 0), self.coord(p, 1), self.coord(p, 2));
        (k * self.dims[1] + j) * self.dims[0] + i
    }

    /// Minimum-image displacement b − a.
    pub fn displacement(&self, a: DVec3, b: DVec3) -> DVec3 {
        minimum_image(b - a, &self.periods)
    }

    /// Calls `f(j, b − a)` for every indexed particle j within `radius` (≤ the build radius) of
    /// point `a` (including a particle at a itself).
    pub fn for_each_within(&self, a: DVec3, radius: f64, x: &[DVec3], mut f: impl FnMut(usize, DVec3)) {
        let c = [self.coord(a, 0) as i64, self.coord(a, 1) as i64, self.coord(a, 2) as i64];
        let r2 = radius * radius;
        let range = |ax: usize| -> Vec<usize> {
            let n = self.dims[ax] as i64;
            let mut v: Vec<usize> = Vec::with_capacity(3);
            for d in -1..=1 {
                let t = c[ax] + d;
                let t = if self.periods[ax].is_some() {
                    t.rem_euclid(n)
                } else if t < 0 || t >= n {
                    continue;
                } else {
                    t
                };
                if !v.contains(&(t as usize)) {
                    v.push(t as usize);
                }
            }
            v
        };
        let (ri, rj, rk) = (range(0), range(1), range(2));
        for &k in &rk {
            for &j in &rj {
                for &i in &ri {
                    let cell = (k * self.dims[1] + j) * self.dims[0] + i;
                    for &p in &self.order[self.start[cell] as usize..self.start[cell + 1] as usize] {
                        let d = self.displacement(a, x[p as usize]);
                        if d.length_squared() <= r2 {
                            f(p as usize, d);
                        }
                    }
                }
            }
        }
    }

    pub fn cell_count(&self) -> usize {
        self.dims[0] * self.dims[1] * self.dims[2]
    }
}

pub fn minimum_image(mut d: DVec3, periods: &Periods) -> DVec3 {
    for a in 0..3 {
        if let Some(l) = periods[a] {
            d[a] -= l * (d[a] / l).round();
        }
    }
    d
}
