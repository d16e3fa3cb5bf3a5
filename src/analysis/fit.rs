//! Least-squares fits shared by the measurements (decay rates, viscosities).

/// Least-squares slope of y(x).
pub fn slope(x: &[f64], y: &[f64]) -> f64 {
    let n = x.len() as f64;
    let mx = x.iter().sum::<f64>() / n;
    let my = y.iter().sum::<f64>() / n;
    let sxy: f64 = x.iter().zip(y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx) * (a - mx)).sum();
    sxy / sxx
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_slope_of_a_line_is_exact() {
        let x = [0.0, 1.0, 2.5, 4.0];
        let y: Vec<f64> = x.iter().map(|x| 3.0 - 0.75 * x).collect();
        assert!((super::slope(&x, &y) + 0.75).abs() < 1e-14);
    }
}
