//! The FCHC lattice gas on the GPU: kernels and 100 steps, bit for bit the CPU's.

use crate::support::*;

/// A small lattice-gas channel with every code path: inlet, outlet copy, a cylinder, p > 0.
fn lattice_gas_channel(
    outlet: phonation::lattice_gas::lattice::Outlet,
    diagonals: phonation::lattice_gas::lattice::Diagonals,
) -> phonation::lattice_gas::lattice::LatticeGas {
    use phonation::lattice_gas::lattice::{Inlet, LatticeGas};
    let mut g = LatticeGas::new([24, 10, 4], 12345, 0.3);
    g.diagonals = diagonals;
    g.inlet = Some(Inlet::new(0.2, 0.15, outlet));
    g.add_cylinder([14.0, 9.0], 4.0);
    g.fill(0.2, |x| [0.1, 0.02 * (x[0] * 0.3).sin(), 0.0, 0.0], 3);
    g.step = 4_000_000_000; // the step counter wraps on both backends alike
    g
}

#[test]
fn lattice_gas_kernels_match_their_cpu_twins() {
    use phonation::gpu::lattice_gas::GpuLatticeGas;
    use phonation::lattice_gas::collision::CollisionTable;
    use phonation::stages::LATTICE_GAS_STEP;
    let Some(ctx) = context() else { return };
    let table = CollisionTable::shared();
    use phonation::lattice_gas::lattice::{Diagonals, Outlet};
    for (outlet, diagonals) in [(Outlet::Copy, Diagonals::OwnPlane), (Outlet::FreeStream, Diagonals::OwnPlane), (Outlet::Copy, Diagonals::AllPerpendicular)] {
        let base = lattice_gas_channel(outlet, diagonals);
        assert!(base.solid.iter().filter(|&&s| s).count() >= 8);
        // stage by stage: each kernel after the CPU ran the stages before it
        for (i, stage) in LATTICE_GAS_STEP.iter().enumerate() {
            let mut cpu = base.clone();
            for s in &LATTICE_GAS_STEP[..i] {
                cpu.run_stage(s.kind, table);
            }
            let mut gpu = GpuLatticeGas::new(&ctx, &cpu, table).unwrap();
            gpu.run_single_stage(stage.kind);
            cpu.run_stage(stage.kind, table);
            let (a, b) = (cpu.cell_words(), gpu.cell_words());
            let differing = a.iter().zip(&b).filter(|(x, y)| x != y).count();
            println!("{outlet:?} outlet, {diagonals:?}, {}: {differing} of {} words differ", stage.name, a.len());
            assert_eq!(differing, 0, "stage {}", stage.name);
        }
    }
}

#[test]
fn lattice_gas_gpu_is_bit_identical_to_the_cpu_after_100_steps() {
    use phonation::gpu::lattice_gas::GpuLatticeGas;
    use phonation::lattice_gas::collision::CollisionTable;
    let Some(ctx) = context() else { return };
    let table = CollisionTable::shared();
    use phonation::lattice_gas::lattice::{Diagonals, Outlet};
    for diagonals in [Diagonals::OwnPlane, Diagonals::AllPerpendicular] {
        let mut cpu = lattice_gas_channel(Outlet::Copy, diagonals);
        let mut gpu = GpuLatticeGas::new(&ctx, &cpu, table).unwrap();
        let start = cpu.cell_words();
        for _ in 0..100 {
            cpu.advance(table);
        }
        gpu.advance(100);
        let (a, b) = (cpu.cell_words(), gpu.cell_words());
        let changed = a.iter().zip(&start).filter(|(x, y)| x != y).count();
        println!("{diagonals:?}: {changed} of {} words changed in 100 steps; particles {}", a.len(), cpu.invariants().particles);
        assert!(changed > a.len() / 2, "the state must have evolved");
        assert_eq!(a, b, "GPU and CPU states differ after 100 steps ({diagonals:?})");
        let mut mirror = cpu.clone();
        gpu.download_into(&mut mirror);
        assert_eq!(mirror.step, cpu.step);
        assert_eq!(gpu.device_step(), cpu.step);
    }
}
