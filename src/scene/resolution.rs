//! A scene at another resolution: the lattice's `domain.cells` times a factor and the
//! particles' `solid.spacing` divided by it, so that the lattice spacing Δx and the particle
//! spacing l₀ shrink together (their ratio, which the coupling checks, is kept) while the domain,
//! the bodies and every physical parameter stay as they are. The time step follows from Δx (the
//! sound speed's limit, or the Mach scaling's). Used by `phonation sweep --key resolution`
//! (convergence studies) and by the example's panel.

use super::SceneError;

/// The pseudo-key of a resolution factor (a sweep's `--key`, the panel's field).
pub const KEY: &str = "resolution";

fn refuse(reason: String) -> SceneError {
    SceneError { field: KEY.into(), reason }
}

/// Scales the scene `table` to `factor` × its lattice: every entry of `domain.cells` must become
/// a whole number (refused naming `resolution` otherwise), `solid.spacing` (if any) is divided
/// by the factor. A lattice-gas scene, whose lengths are lattice units, has no `domain.cells`
/// and is refused.
pub fn at_resolution(table: &mut toml::Table, factor: f64) -> Result<(), SceneError> {
    if !(factor.is_finite() && factor > 0.0) {
        return Err(refuse(format!("{factor} must be a positive factor of the scene's lattice")));
    }
    let cells = table
        .get_mut("domain")
        .and_then(|d| d.get_mut("cells"))
        .and_then(|c| c.as_array_mut())
        .ok_or_else(|| refuse("the scene has no [domain] cells (a lattice gas's lengths are in lattice units)".into()))?;
    let mut scaled = Vec::with_capacity(cells.len());
    let given: Vec<String> = cells.iter().map(|c| c.to_string()).collect();
    for c in cells.iter() {
        let n = c.as_integer().ok_or_else(|| refuse("the scene's domain.cells are not integers".into()))? as f64 * factor;
        if (n - n.round()).abs() > 1e-9 || n < 1.0 {
            return Err(refuse(format!("×{factor} gives {n} cells along an axis (domain.cells = [{}]), not a whole number", given.join(", "))));
        }
        scaled.push(toml::Value::Integer(n.round() as i64));
    }
    *cells = scaled.into_iter().collect();
    if let Some(l0) = table.get_mut("solid").and_then(|t| t.get_mut("spacing")) {
        let v = l0.as_float().or_else(|| l0.as_integer().map(|i| i as f64)).ok_or_else(|| refuse("the scene's solid.spacing is not a number".into()))?;
        *l0 = toml::Value::Float(v / factor);
    }
    Ok(())
}

/// [`at_resolution`] on a scene text; returns the rescaled scene as TOML text.
pub fn text_at_resolution(text: &str, factor: f64) -> Result<String, SceneError> {
    let mut table: toml::Table = toml::from_str(text).map_err(|e| SceneError::from_toml("scene", &e, text))?;
    at_resolution(&mut table, factor)?;
    Ok(toml::to_string(&table).expect("a table serialises"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_glottis_at_three_quarters_has_three_quarters_of_the_cells_and_the_same_ratio_of_spacings() {
        let text = crate::scene::builtin("glottis_2d_c").unwrap();
        let t: toml::Table = text_at_resolution(text, 0.75).unwrap().parse().unwrap();
        let cells: Vec<i64> = t["domain"]["cells"].as_array().unwrap().iter().map(|c| c.as_integer().unwrap()).collect();
        assert_eq!(cells, [93, 96]);
        let l0 = t["solid"]["spacing"].as_float().unwrap();
        assert!((l0 - 0.006103515625 / 0.75).abs() < 1e-15, "{l0}");
        // the domain and the physics are untouched
        assert_eq!(t["domain"]["size"], text.parse::<toml::Table>().unwrap()["domain"]["size"]);
        let sc = crate::scene::coupled::CoupledScene::parse(&toml::to_string(&t).unwrap()).unwrap();
        let dx = sc.fluid.units.dx;
        assert!((dx - 1.5625 / 96.0).abs() < 1e-12, "Δx = {dx}");
    }

    #[test]
    fn a_factor_that_splits_a_cell_or_is_not_positive_is_refused_naming_resolution() {
        let text = crate::scene::builtin("glottis_2d_c").unwrap();
        for (f, why) in [(0.3, "not a whole number"), (0.0, "positive"), (f64::NAN, "positive")] {
            let e = text_at_resolution(text, f).unwrap_err();
            assert_eq!(e.field, "resolution");
            assert!(e.reason.contains(why), "{f}: {}", e.reason);
        }
        let gas = crate::scene::builtin("lattice_gas_wake").unwrap();
        assert!(text_at_resolution(gas, 2.0).unwrap_err().reason.contains("lattice units"));
    }
}
