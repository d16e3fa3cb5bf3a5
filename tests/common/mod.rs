//! Helpers shared by the test binaries: the walk over a scene's keys of "no setting silently
//! ignored" (tests/scenes.rs on the CPU, tests/gpu/ on the GPU).

#![allow(dead_code)] // each test binary uses its part

use toml::Value;

/// Keys that set outputs or the run's length, not the physics (last path element).
pub const OUTPUT_ONLY: [&str; 12] =
    ["duration", "steps", "probe_every", "snapshots", "output_every", "every", "coarse_block", "vtk", "window_fraction", "f0_min", "f0_max", "position"];

/// The path (table keys, `#i` for array items) of every number and flag of `v`.
pub fn leaves(v: &Value, here: &mut Vec<String>, out: &mut Vec<Vec<String>>) {
    match v {
        Value::Table(t) => t.iter().for_each(|(k, x)| {
            here.push(k.clone());
            leaves(x, here, out);
            here.pop();
        }),
        Value::Array(a) => a.iter().enumerate().for_each(|(i, x)| {
            here.push(format!("#{i}"));
            leaves(x, here, out);
            here.pop();
        }),
        Value::Integer(_) | Value::Float(_) | Value::Boolean(_) => out.push(here.clone()),
        _ => {}
    }
}

/// The value at `path`.
pub fn at<'a>(v: &'a mut Value, path: &[String]) -> &'a mut Value {
    path.iter().fold(v, |v, k| match k.strip_prefix('#') {
        Some(i) => &mut v.as_array_mut().unwrap()[i.parse::<usize>().unwrap()],
        None => v.as_table_mut().unwrap().get_mut(k).unwrap(),
    })
}

/// Whether the key at `p` of scene `base` is left out of the walk: outputs and the run's length,
/// probes, and the keys whose effect two steps cannot show, each with where it is shown:
/// contact parameters act only once bodies touch (no scene here touches in its first steps;
/// tests/solid.rs `contact` tests measure them); a wall's normal is normalised (a longer normal
/// is the same wall); in 2D (plane strain) the out-of-plane shear moduli G_yz, G_zx do not enter
/// (seed §3.4.1, see the glottis scenes' comments; the 3D solid tests use them); selection boxes
/// (clamps, loads) reach beyond the body, where a nudged bound selects the same particles, and
/// the fold's clamped strip lies deep inside the fold, beyond what two steps move (tests/solid.rs:
/// clamps and loads tests).
pub fn left_out(base: &Value, p: &[String]) -> bool {
    let last = p.iter().rev().find(|k| !k.starts_with('#')).unwrap();
    // fluid probes and the coupling's particle probes are outputs
    if OUTPUT_ONLY.contains(&last.as_str()) || p[0] == "probes" || p.len() > 1 && p[0] == "coupling" && p[1] == "probes" {
        return true;
    }
    let joined = p.join(".");
    let plane_strain_shear =
        base.get("solid").and_then(|s| s.get("dimension")).and_then(Value::as_integer) == Some(2) && last == "shear" && !joined.ends_with("#2");
    let selection = joined.starts_with("solid.clamps.") || joined.starts_with("solid.loads.") && !joined.contains("force") || last == "fixed_depth";
    joined.starts_with("solid.contact.") || joined.contains("walls") && joined.contains("normal") || plane_strain_shear || selection
}

/// `v` nudged: an integer by one, a number by 25 % (enough to add a row of particles to a box
/// or a clamp; 1e-3 for a zero), a flag flipped.
pub fn nudge(v: &mut Value) {
    *v = match v.clone() {
        Value::Integer(i) => Value::Integer(i + 1),
        Value::Float(x) => Value::Float(if x == 0.0 { 1e-3 } else { x * 1.25 }),
        Value::Boolean(b) => Value::Boolean(!b),
        _ => unreachable!("a leaf is a number or a flag"),
    };
}

/// Every key of `text` not [`left_out`], nudged: (path, the nudged scene's text).
pub fn nudged_scenes(text: &str) -> Vec<(String, String)> {
    let base: Value = Value::Table(text.parse::<toml::Table>().unwrap());
    let mut paths = Vec::new();
    leaves(&base, &mut Vec::new(), &mut paths);
    paths
        .into_iter()
        .filter(|p| !left_out(&base, p))
        .map(|p| {
            let mut doc = base.clone();
            nudge(at(&mut doc, &p));
            (p.join("."), toml::to_string(doc.as_table().unwrap()).unwrap())
        })
        .collect()
}
