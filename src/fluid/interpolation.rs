//! Multilinear interpolation on the lattice over fluid nodes only: the image stencils of the
//! ghost nodes ([`super::layout`], [`super::thin_wall`]) and the stencils of sampled points
//! ([`super::moving`]). Units: lattice cells.

use super::grid::Grid;

/// The 2ᴰ corners of the cell around `p` (interior node coordinates) with their multilinear
/// weights (the base corner rounds along unused axes), without an allocation: asked for every
/// ghost's image point at every step of a moving body.
pub(super) fn multilinear_corners(dim: usize, p: [f64; 3]) -> impl Iterator<Item = ([i64; 3], f64)> {
    let base: [i64; 3] = std::array::from_fn(|a| if a < dim { p[a].floor() as i64 } else { p[a].round() as i64 });
    let frac: [f64; 3] = std::array::from_fn(|a| if a < dim { p[a] - base[a] as f64 } else { 0.0 });
    (0..1usize << dim).map(move |c| {
        let mut x = base;
        let mut w = 1.0;
        for a in 0..dim {
            if c & (1 << a) != 0 {
                x[a] += 1;
                w *= frac[a];
            } else {
                w *= 1.0 - frac[a];
            }
        }
        (x, w)
    })
}

/// Multilinear interpolation weights at `p` over fluid nodes only (renormalised). Falls back to
/// the nearest fluid node within two cells when the cell around `p` holds no fluid node.
pub(super) fn interpolation_stencil(grid: &Grid, p: [f64; 3], fluid_at: &dyn Fn([i64; 3]) -> Option<usize>) -> Vec<(usize, f64)> {
    let dim = grid.dim;
    let base: [i64; 3] = std::array::from_fn(|a| if a < dim { p[a].floor() as i64 } else { p[a].round() as i64 });
    let mut out: Vec<(usize, f64)> = Vec::new();
    let mut total = 0.0;
    for (x, w) in multilinear_corners(dim, p) {
        if w <= 1e-12 {
            continue;
        }
        if let Some(i) = fluid_at(x) {
            out.push((i, w));
            total += w;
        }
    }
    if total > 1e-6 {
        out.iter_mut().for_each(|(_, w)| *w /= total);
        return out;
    }
    // Nearest fluid node.
    let mut best: Option<(usize, f64)> = None;
    let r = 2i64;
    for dz in if dim == 3 { -r..=r } else { 0..=0 } {
        for dy in -r..=r {
            for dx in -r..=r {
                let x = [base[0] + dx, base[1] + dy, base[2] + dz];
                if let Some(i) = fluid_at(x) {
                    let d2 = (x[0] as f64 - p[0]).powi(2) + (x[1] as f64 - p[1]).powi(2) + (x[2] as f64 - p[2]).powi(2);
                    if best.is_none_or(|(_, bd)| d2 < bd) {
                        best = Some((i, d2));
                    }
                }
            }
        }
    }
    best.map(|(i, _)| vec![(i, 1.0)]).unwrap_or_default()
}
