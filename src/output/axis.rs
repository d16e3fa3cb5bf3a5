//! Axis labels and ranges shared by the SVG plots (`output::voice`, plotters) and the panel's
//! live plots (`render::plots`, egui_plot).

/// The plotted range of values spanning [lo, hi], 5 % added on each side. A series that does
/// not vary (a closed glottis: U_g = 0 throughout) gets a range of ±10 % of its magnitude (±0.5
/// around zero) instead of one set by round-off.
pub fn value_range(lo: f64, hi: f64) -> (f64, f64) {
    if !(lo.is_finite() && hi.is_finite()) {
        return (0.0, 1.0);
    }
    let scale = lo.abs().max(hi.abs());
    if hi - lo <= 1e-9 * scale || scale == 0.0 {
        let half = if scale > 0.0 { 0.1 * scale } else { 0.5 };
        return (lo - half, hi + half);
    }
    let pad = 0.05 * (hi - lo);
    (lo - pad, hi + pad)
}

/// A tick label of `v` on an axis spanning `span`: the decimals the tick spacing (about a tenth
/// of the span) resolves and no more, scientific notation for magnitudes of 10⁵ and more or
/// below 10⁻³, and 0 for a value that is zero to the spacing (plotters' own labels print the
/// round-off of a tick at zero with eleven decimals, and 800000.0 for 8·10⁵).
pub fn tick_label(v: f64, span: f64) -> String {
    let step = span.abs() / 10.0;
    if !(step > 0.0 && v.is_finite()) {
        return format!("{v}");
    }
    if v.abs() < 1e-6 * step {
        return "0".into();
    }
    let step_exp = step.log10().floor();
    let big = span.abs().max(v.abs());
    if !(1e-3..1e5).contains(&big) {
        let digits = (v.abs().log10().floor() - step_exp).clamp(0.0, 6.0) as usize;
        return format!("{v:.digits$e}");
    }
    let decimals = (-step_exp).clamp(0.0, 12.0) as usize;
    format!("{v:.decimals$}")
}

#[cfg(test)]
mod tests {
    use super::{tick_label, value_range};

    #[test]
    fn tick_labels_carry_the_digits_of_the_tick_spacing() {
        let cases = [
            (1.2e-13, 600.0, "0"),
            (200.0, 650.0, "200"),
            (445.0, 50.0, "445"),
            (0.3, 1.0, "0.3"),
            (-100.0, 120.0, "-100"),
            (-800000.0, 1.4e6, "-8e5"),
            (250000.0, 1.4e6, "2e5"),
            (1.25e6, 1.0e6, "1.2e6"),
            (5e-11, 1e-10, "5e-11"),
            (0.004, 0.01, "0.004"),
        ];
        for (v, span, want) in cases {
            assert_eq!(tick_label(v, span), want, "{v} on a span of {span}");
        }
        // a series that does not vary gets a readable range, not one set by round-off
        assert_eq!(value_range(0.0, 0.0), (-0.5, 0.5));
        assert_eq!(value_range(590.0, 590.0), (531.0, 649.0));
        assert_eq!(value_range(0.0, 100.0), (-5.0, 105.0));
    }
}
