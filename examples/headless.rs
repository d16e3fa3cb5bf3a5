//! Embedding the solver as a library, without Bevy: load a built-in scene, step it on the CPU
//! backend, and read the macroscopic state at its probes in physical units.
//!
//!     cargo run --release --no-default-features --example headless

use phonation::scene;

fn main() -> anyhow::Result<()> {
    let sc = scene::load(scene::builtin("glottal_jet").expect("built-in scene"))?;
    let mut solver = sc.build_solver();
    let u = sc.units;
    for _ in 0..10 {
        solver.run(500)?;
        let t_ms = u.time_to_physical(solver.time) * 1e3;
        for (name, node) in &sc.probes {
            let m = solver.macro_at_coords(*node);
            println!(
                "t = {t_ms:.4} ms  {name:12}  p = {:8.1} dyn/cm²  u = {:8.1} cm/s",
                u.gauge_pressure_to_physical(m.pressure()),
                u.velocity_to_physical(m.u[0])
            );
        }
    }
    Ok(())
}
