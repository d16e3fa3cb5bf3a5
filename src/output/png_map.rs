//! PNG colour maps of a [`super::fields::Slice`]: a perceptually ordered blue–white–red map for
//! signed fields, a dark-to-yellow map for magnitudes; solids drawn grey. y points up.

use super::fields::Slice;
use std::io::BufWriter;
use std::path::Path;

fn lerp(a: [f64; 3], b: [f64; 3], t: f64) -> [f64; 3] {
    [a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t, a[2] + (b[2] - a[2]) * t]
}

fn ramp(stops: &[[f64; 3]], t: f64) -> [u8; 3] {
    let t = t.clamp(0.0, 1.0) * (stops.len() - 1) as f64;
    let i = (t.floor() as usize).min(stops.len() - 2);
    let c = lerp(stops[i], stops[i + 1], t - i as f64);
    [(c[0] * 255.0) as u8, (c[1] * 255.0) as u8, (c[2] * 255.0) as u8]
}

const SEQUENTIAL: [[f64; 3]; 5] = [[0.05, 0.03, 0.25], [0.35, 0.1, 0.5], [0.75, 0.2, 0.4], [0.98, 0.55, 0.15], [0.99, 0.95, 0.4]];
const DIVERGING: [[f64; 3]; 3] = [[0.15, 0.3, 0.75], [0.97, 0.97, 0.97], [0.75, 0.1, 0.1]];

/// The range of `slice`'s finite values mapped to the ends of the colour scale; `signed`:
/// symmetric about zero. A slice with one value (or none) gets a unit-wide range.
pub fn colour_range(slice: &Slice, signed: bool) -> (f64, f64) {
    let vals: Vec<f64> = slice.values.iter().flatten().copied().filter(|v| v.is_finite()).collect();
    let (mut lo, mut hi) = vals.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| (a.min(*v), b.max(*v)));
    if signed {
        let m = lo.abs().max(hi.abs()).max(1e-300);
        lo = -m;
        hi = m;
    }
    if !(hi > lo) {
        hi = lo + 1.0;
    }
    (lo, hi)
}

/// The colour of a node's value in `range` (solids and non-finite values grey).
pub fn colour(v: Option<f64>, (lo, hi): (f64, f64), signed: bool) -> [u8; 3] {
    match v {
        Some(v) if v.is_finite() => {
            let t = (v - lo) / (hi - lo);
            if signed { ramp(&DIVERGING, t) } else { ramp(&SEQUENTIAL, t) }
        }
        _ => [110, 110, 110],
    }
}

/// RGBA8 pixels of `slice` in rows from the top (y up in the world), in [`colour`]'s map over
/// [`colour_range`], and that range: the image the Bevy slice draws (the GPU slice kernel,
/// shaders/slice.wgsl, is its twin).
pub fn rgba_top_down(slice: &Slice, signed: bool) -> (Vec<u8>, (f64, f64)) {
    let range = colour_range(slice, signed);
    let mut data = Vec::with_capacity(4 * slice.nx * slice.ny);
    for row in 0..slice.ny {
        let y = slice.ny - 1 - row;
        for x in 0..slice.nx {
            let rgb = colour(slice.values[x + slice.nx * y], range, signed);
            data.extend_from_slice(&[rgb[0], rgb[1], rgb[2], 255]);
        }
    }
    (data, range)
}

/// Writes `slice` as an RGB PNG, scaled up by an integer factor so that small grids stay
/// visible. `signed`: symmetric range around zero.
pub fn write_png(path: &Path, slice: &Slice, signed: bool) -> std::io::Result<(f64, f64)> {
    let (lo, hi) = colour_range(slice, signed);
    let scale = (512 / slice.nx.max(slice.ny)).max(1);
    let (w, h) = (slice.nx * scale, slice.ny * scale);
    let mut data = vec![0u8; w * h * 3];
    for py in 0..h {
        let y = slice.ny - 1 - py / scale;
        for px in 0..w {
            let x = px / scale;
            let rgb = colour(slice.values[x + slice.nx * y], (lo, hi), signed);
            data[(py * w + px) * 3..(py * w + px) * 3 + 3].copy_from_slice(&rgb);
        }
    }
    let file = std::fs::File::create(path)?;
    let mut enc = png::Encoder::new(BufWriter::new(file), w as u32, h as u32);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    let mut wr = enc.write_header().map_err(std::io::Error::other)?;
    wr.write_image_data(&data).map_err(std::io::Error::other)?;
    Ok((lo, hi))
}
