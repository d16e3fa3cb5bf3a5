//! The momentum-conserving coupling (method 2, seed 000 §2.4.2) on the CPU: one coupled step
//! runs [`crate::stages::COUPLED_CONSERVING_STEP`] ([`super::solver::CoupledSolver`]).
//!
//! 1. **fluid_geometry** — every body's particles define a level set on the lattice (2.124);
//!    its zero contour is the wall the fluid sees (a [`KernelLevelSet`] obstacle: the ghost
//!    nodes take their depth by Newton steps on L (the zero crossing of 2.125, found along ∇L
//!    rather than along a lattice link), the normal −∇L/|∇L| (2.126) and the wall velocity
//!    interpolated from the particles with the kernel weights, 2.130). A node the
//!    body covers leaves the fluid with its momentum, which the body receives; a node it
//!    uncovers enters the fluid with momentum the body gives up.
//! 2. **fluid** — one FDLB step; the momentum each wall node takes out of the air through its
//!    faces with fluid nodes is recorded link by link ([`super::momentum_exchange`]: the
//!    W_in + W_out of 2.122–2.123 for the finite-difference advection).
//! 3. **momentum_exchange** — each wall node's momentum is shared among the particles within
//!    r_e of it with the kernel weights w_j normalised to sum to one (2.127–2.128; the seed
//!    normalises by |L|, which does not sum to one, and the sum must be one for the solid to
//!    receive exactly what the air lost) and becomes a load over the step.
//! 4. **solid** — the solid steps (explicit sub-steps or implicit) with those loads and the
//!    air's added mass in its mass matrix (2.129, [`super::added_mass`]).
//!
//! Everything the air loses, the particles gain: fluid + solid momentum (+ the added mass's
//! Σ m_a v in transit) is conserved to round-off (the solid's internal forces are pairwise),
//! with no surface polygon. The exchange
//! is counted against the air at rest at the reference pressure p₀ (gauge), as method 1's
//! tractions are: a body's reference shape is its shape in air at p₀.
//!
//! The walls of a step move at the particles' velocity at its start (a staggered exchange, as
//! in method 1); the added mass (2.129) puts the air's answer to the new velocity into the
//! solid's update, which is what lets light bodies be carried.
//!
//! Units: the solid in the scene's physical units, the fluid in lattice units.

use super::momentum_exchange::step_with_exchange;
use super::solver::{CoupledBody, CoupledSolver};
use crate::fluid::layout::Layout;
use crate::fluid::{KernelLevelSet, LayoutChange, Macro, NodeChange, Shape};
use crate::step::{Instability, Site};
use glam::{DVec3, DVec4};
use rayon::prelude::*;
use std::sync::Arc;

/// Options of the momentum-conserving coupling.
#[derive(Clone, Copy, Debug)]
pub struct ConservingOptions {
    /// Kernel radius r_e of the level set (lattice cells); the level set's contour is smooth
    /// to a fraction of a cell for r_e ≥ 2 cells (`level_set` tests).
    pub kernel_radius: f64,
    /// Largest particle displacement per fluid step (cells).
    pub max_cells_per_step: f64,
    /// The air's added mass in the solid's update (2.129, [`super::added_mass`]); without it
    /// the exchange is purely staggered.
    pub added_mass: bool,
}

impl Default for ConservingOptions {
    fn default() -> Self {
        Self { kernel_radius: 2.0, max_cells_per_step: 1.0, added_mass: true }
    }
}

/// Method 2's walls at the particles' current positions, built but not yet installed
/// ([`CoupledSolver::next_level_set_walls`], [`CoupledSolver::install_level_set_walls`]).
pub struct LevelSetWalls {
    /// The fluid's layout with the bodies' level-set walls and the rigid obstacles.
    pub layout: Layout,
    sets: Vec<Arc<KernelLevelSet>>,
    /// The particles' positions (cells) the walls are built from.
    points: Vec<DVec3>,
    change: std::cell::OnceCell<LayoutChange>,
}

impl LevelSetWalls {
    /// The change of layout installing these walls in a fluid of layout `current` makes (made
    /// once and kept: the walls are built for the fluid they are installed in).
    pub fn change(&self, current: &Layout) -> &LayoutChange {
        self.change.get_or_init(|| LayoutChange::between(current, &self.layout))
    }

    /// Whether installing these walls in a fluid of layout `current` makes nodes enter or leave
    /// the fluid (their populations, and their fluid neighbours', are then read and written).
    pub fn changes_nodes(&self, current: &Layout) -> bool {
        !self.change(current).nodes.is_empty()
    }
}

/// Method 2's state between stages.
#[derive(Clone, Debug)]
pub struct Exchange {
    /// Surface level φ of each body (2.124), from its reference surface.
    pub phi: Vec<f64>,
    /// Populations of the air at rest in the reference state (ρ = 1, θ₀): the exchange is
    /// counted against it (gauge momentum, [`super::momentum_exchange::add_face_fluxes`]).
    reference: Vec<f64>,
    /// Momentum (x, y, z) and mass (w) taken out of the air per padded node in the current
    /// step (lattice units).
    wall: Vec<DVec4>,
    /// The nodes the geometry stage booked momentum to in `wall` since the last exchange.
    changed: Vec<usize>,
    /// The level sets the walls of the current step were built from (the particles do not move
    /// before the exchange hands them the momentum), shared with the layout's walls.
    sets: Vec<Arc<KernelLevelSet>>,
    /// Particle positions (cells) the geometry was last built from.
    pub(super) built: Option<Vec<DVec3>>,
    /// Momentum handed over the run to walls that are no coupled body (rigid obstacles, face
    /// walls: no particle within r_e), physical units.
    pub walls: DVec3,
    /// Momentum the bodies received over the run from nodes they covered minus what the fresh
    /// nodes they uncovered took (physical units): part of the exchange, reported apart.
    pub node_changes: DVec3,
    /// Mass the walls took out of the air over the run (lattice units; ≈ 0 for a closed body).
    pub mass_to_walls: f64,
    /// Σ over the run of the momentum the bodies received in their own frame, Σ (p − u_w m)
    /// per wall node (physical units): Wen et al.'s Galilean-invariant momentum exchange, a
    /// diagnostic (what the bodies receive is p, which conserves the total exactly).
    pub wall_frame: DVec3,
}

impl Exchange {
    /// Momentum (xyz) and mass (w) each padded lattice node took out of the air in the current
    /// step (lattice units; consumed by the momentum_exchange stage).
    pub fn wall(&self) -> &[DVec4] {
        &self.wall
    }

    /// The populations of the air at rest in the reference state (ρ = 1, θ₀) that the face
    /// fluxes are counted against (one per stored value of a node).
    pub fn reference(&self) -> &[f64] {
        &self.reference
    }

    /// The level sets of the current step's walls, one per coupled body (its particles in
    /// index order).
    pub fn sets(&self) -> &[Arc<KernelLevelSet>] {
        &self.sets
    }

    pub(super) fn new(c: &CoupledSolver, o: ConservingOptions) -> Self {
        let eq = &c.fluid.eq;
        let mut reference = vec![0.0; eq.values_per_node()];
        let mut shell_w = vec![0.0; eq.set.shells.len()];
        eq.feq_into(&Macro { rho: 1.0, u: [0.0; 3], theta: c.units.theta0 }, &mut shell_w, &mut reference);
        let phi = c.bodies.iter().map(|b| c.surface_level(b, o)).collect();
        Exchange {
            phi,
            reference,
            wall: vec![DVec4::ZERO; c.fluid.layout.grid.len()],
            changed: Vec::new(),
            sets: Vec::new(),
            built: None,
            walls: DVec3::ZERO,
            node_changes: DVec3::ZERO,
            mass_to_walls: 0.0,
            wall_frame: DVec3::ZERO,
        }
    }

    /// Forgets the momentum booked so far (the air inside the bodies at the start).
    pub(super) fn clear(&mut self) {
        self.wall.iter_mut().for_each(|w| *w = DVec4::ZERO);
        self.changed.clear();
        self.node_changes = DVec3::ZERO;
        self.mass_to_walls = 0.0;
        self.wall_frame = DVec3::ZERO;
    }
}

impl CoupledSolver {
    /// The clamp of r in the level set's kernel (cells): r_e/2, so that w(r) = r_e/max(r, r_e/2)
    /// − 1 is bounded by one and its gradient by 4/r_e. The seed's kernel is singular at the
    /// particles; clamped at l₀/4 (as first built), L and ∇L spiked at the particles on a scale
    /// the lattice cannot resolve, so the ghost nodes' depth and normal depended on where the
    /// particles sat between nodes: a fixed cylinder's drag (D = 10) varied by ±8 % with its
    /// sub-cell position and a towed one differed from it by +7.6 %; clamped at r_e/2, ±0.4 %
    /// and −0.3 % (validation::fsi::towed_cylinder).
    fn r_min(&self) -> f64 {
        0.5 * self.kernel_radius()
    }

    fn kernel_radius(&self) -> f64 {
        match self.method {
            super::solver::Method::Conserving(o) => o.kernel_radius,
            super::solver::Method::Weak(_) => ConservingOptions::default().kernel_radius,
        }
    }

    /// φ of `body`: the mean kernel sum at its surface points in the reference configuration.
    fn surface_level(&self, body: &CoupledBody, o: ConservingOptions) -> f64 {
        let p = &self.solid.particles;
        let members: Vec<DVec3> = (0..p.len()).filter(|&i| p.body[i] == body.surface.body).map(|i| DVec3::from_array(self.to_lattice(p.position[i]))).collect();
        let surface: Vec<DVec3> = body.surface.points(p).into_iter().map(|x| DVec3::from_array(self.to_lattice(x))).collect();
        super::level_set::surface_level(&members, &surface, o.kernel_radius, self.r_min())
    }

    /// Method 2's surface level φ of every body (empty for method 1).
    pub fn surface_levels(&self) -> &[f64] {
        self.exchange.as_ref().map_or(&[], |e| &e.phi)
    }

    /// Method 2's exchange state (φ, momentum to non-body walls, node changes).
    pub fn exchange(&self) -> Option<&Exchange> {
        self.exchange.as_ref()
    }

    /// Momentum handed over the run to walls that are no coupled body (method 2; physical).
    pub fn momentum_to_walls(&self) -> DVec3 {
        self.exchange.as_ref().map_or(DVec3::ZERO, |e| e.walls)
    }

    /// The level set of every body at the particles' current positions and velocities
    /// (method 2; φ = 0 under method 1, which has no calibration).
    pub fn level_sets(&self) -> Vec<KernelLevelSet> {
        let p = &self.solid.particles;
        self.level_sets_through(|i| self.to_lattice(p.position[i]))
    }

    /// [`Self::level_sets`] with particle i at lattice position `x(i)` (cells: the current
    /// positions), moving at its current velocity.
    fn level_sets_through(&self, x: impl Fn(usize) -> [f64; 3] + Sync) -> Vec<KernelLevelSet> {
        let (p, unit) = (&self.solid.particles, self.units.velocity);
        self.level_sets_of(x, |i| (p.velocity[i] / unit).to_array())
    }

    /// The level set of every body for drawing its surface (lattice coordinates): method 2's
    /// walls as the air sees them; under method 1 (which needs no φ) the same level sets with φ
    /// calibrated on the bodies' reference surfaces as method 2 would.
    pub fn drawn_level_sets(&self) -> Vec<KernelLevelSet> {
        let mut sets = self.level_sets();
        if self.exchange.is_none() {
            for (set, b) in sets.iter_mut().zip(&self.bodies) {
                set.phi = self.surface_level(b, ConservingOptions::default());
            }
        }
        sets
    }

    /// The level sets of particles at lattice positions `points`, at rest.
    pub(super) fn level_sets_at(&self, points: &[DVec3]) -> Vec<KernelLevelSet> {
        self.level_sets_of(|i| points[i].to_array(), |_| [0.0; 3])
    }

    /// Each body's level set with particle i at `x(i)` moving at `v(i)` (lattice units), each
    /// body's members gathered straight from them (no whole-solid copy between).
    fn level_sets_of(&self, x: impl Fn(usize) -> [f64; 3] + Sync, v: impl Fn(usize) -> [f64; 3] + Sync) -> Vec<KernelLevelSet> {
        // the bodies' sets built side by side on the pool (each set's own loops share it too)
        let members: Vec<&[usize]> = self.members.bodies().collect();
        members
            .par_iter()
            .enumerate()
            .map(|(k, members)| {
                let phi = self.surface_levels().get(k).copied().unwrap_or(0.0);
                let positions = members.par_iter().with_min_len(4096).map(|&i| x(i)).collect();
                let velocities = members.par_iter().with_min_len(4096).map(|&i| v(i)).collect();
                KernelLevelSet::new(positions, velocities, self.kernel_radius(), self.r_min(), phi)
            })
            .collect()
    }

    /// Method 2's fluid_geometry stage: the level-set walls; covered and uncovered nodes'
    /// momentum booked to the walls.
    pub(super) fn level_set_geometry(&mut self) -> Result<(), Instability> {
        let walls = self.next_level_set_walls()?;
        self.install_level_set_walls(walls);
        Ok(())
    }

    /// The first half of method 2's fluid_geometry stage, which leaves the fluid untouched:
    /// checks how far the particles moved since the walls were last built (at most
    /// `max_cells_per_step`) and builds the fluid's layout with the bodies' level sets at the
    /// particles' current positions and velocities. A backend that keeps the populations
    /// elsewhere (the GPU) brings them into `self.fluid` before the second half
    /// ([`Self::install_level_set_walls`]) when [`LevelSetWalls::changes_nodes`].
    pub fn next_level_set_walls(&self) -> Result<LevelSetWalls, Instability> {
        self.next_level_set_walls_with(&crate::fluid::OnThePool)
    }

    /// [`Self::next_level_set_walls`] with the level sets' questions (the nodes' sides, the
    /// ghosts' wall points) answered by `queries` (a device's twin, one call per body and
    /// question: [`crate::fluid::LevelSetQueries`]).
    pub fn next_level_set_walls_with(&self, queries: &dyn crate::fluid::LevelSetQueries) -> Result<LevelSetWalls, Instability> {
        let super::solver::Method::Conserving(o) = self.method else { panic!("level-set walls are method 2's") };
        // on the pool's threads: the 3D glottis moves 665,344 particles a step
        let points: Vec<DVec3> = self.solid.particles.position.par_iter().with_min_len(4096).map(|x| DVec3::from_array(self.to_lattice(*x))).collect();
        let ex = self.exchange.as_ref().expect("method 2 has its exchange state");
        if let Some(old) = &ex.built {
            // the farthest move, the first particle of those that moved as far
            let farther = |m: (usize, f64), c: (usize, f64)| if c.1 > m.1 || (c.1 == m.1 && c.0 < m.0) { c } else { m };
            let (i, d) = old
                .par_iter()
                .zip(&points)
                .with_min_len(4096)
                .map(|(a, b)| (*a - *b).length())
                .enumerate()
                .fold(|| (usize::MAX, 0.0), |m, (i, d)| farther(m, (i, d)))
                .reduce(|| (usize::MAX, 0.0), farther);
            if d > o.max_cells_per_step {
                return Err(self.moved_too_far(Site::Particle(i), "particle displacement in one step (cells)", d, o.max_cells_per_step));
            }
        }
        let sets: Vec<Arc<KernelLevelSet>> = self.level_sets_through(|i| points[i].to_array()).into_iter().map(Arc::new).collect();
        let mut all = self.obstacles.clone();
        all.extend(self.body_walls(sets.iter().cloned().map(Shape::KernelLevelSet)));
        Ok(LevelSetWalls { layout: self.fluid.layout_with_level_sets(&all, queries), sets, points, change: Default::default() })
    }

    /// The second half of method 2's fluid_geometry stage: installs `walls` in the fluid
    /// (fresh nodes initialised from their fluid neighbours); nodes that change side book their
    /// momentum to the walls (covered: the air's momentum to the body; uncovered: the body pays
    /// for the fresh node's).
    pub fn install_level_set_walls(&mut self, walls: LevelSetWalls) {
        let plan = walls.change(&self.fluid.layout).clone();
        let LevelSetWalls { layout, sets, points, .. } = walls;
        let ch = self.fluid.apply_layout(layout, &plan);
        let q = self.fluid.eq.q();
        let unit = self.momentum_unit();
        let ex = self.exchange.as_mut().expect("method 2");
        ex.sets = sets;
        ex.built = Some(points);
        // the nodes that changed side, in node order: the plan's list, not a scan of the lattice
        for (node, change) in &plan.nodes {
            let (node, was) = (*node, matches!(change, NodeChange::Covered));
            let f = self.fluid.node_populations(node);
            let m: DVec4 = self.fluid.eq.cf[..q].iter().zip(&f[..q]).map(|(c, f)| DVec4::new(c[0], c[1], c[2], 1.0) * *f).sum();
            let m = if was { m } else { -m };
            ex.wall[node] += m;
            ex.changed.push(node);
            ex.node_changes += m.truncate() * unit;
        }
        self.geometry.uncovered += ch.uncovered;
        self.geometry.covered += ch.covered;
        self.geometry.isolated += ch.isolated;
        self.geometry.mass_change += ch.mass_change;
    }

    /// Method 2's fluid stage: one fluid step, recording what each wall node took out of the air.
    pub(super) fn fluid_step_with_exchange(&mut self) -> Result<(), Instability> {
        let ex = self.exchange.as_mut().expect("method 2");
        let flux = step_with_exchange(&mut self.fluid, Some(&ex.reference))?;
        ex.wall.iter_mut().zip(flux).for_each(|(w, f)| *w += f);
        Ok(())
    }

    /// The level sets of the coupled bodies (the current walls' points and velocities, bodies in
    /// order) with the particle index of each of their points, one after the other: the weights of
    /// the momentum exchange (2.127–2.128) normalised over all bodies at once, as the
    /// `momentum_exchange` stage normalises them — for a backend that runs that stage itself. The
    /// sets are the geometry stage's own, bins and all: nothing is binned again.
    pub fn exchange_sets(&self) -> (&[Arc<KernelLevelSet>], &[usize]) {
        let ex = self.exchange.as_ref().expect("method 2");
        (&ex.sets, self.members.order())
    }

    /// The momentum (xyz) and mass (w) booked by the geometry stage to the padded nodes that
    /// changed side, (node, momentum) for each, taken and cleared: a backend whose fluid step
    /// records the face fluxes elsewhere adds them to those before its momentum exchange
    /// (lattice units).
    pub fn take_node_change_momentum(&mut self) -> Vec<(usize, DVec4)> {
        let ex = self.exchange.as_mut().expect("method 2");
        let changed = std::mem::take(&mut ex.changed);
        changed.into_iter().map(|node| (node, std::mem::take(&mut ex.wall[node]))).filter(|(_, m)| *m != DVec4::ZERO).collect()
    }

    /// Adds what another backend's momentum exchange measured over one step to the exchange's
    /// run sums: the momentum of wall nodes with no particle within r_e, the mass all wall nodes
    /// took and Σ (p − u_w m) (lattice units in; kept in the units of [`Exchange`]'s fields).
    pub fn add_exchange_diagnostics(&mut self, walls: DVec3, mass: f64, wall_frame: DVec3) {
        let to_physical = self.momentum_unit();
        let ex = self.exchange.as_mut().expect("method 2");
        ex.walls += walls * to_physical;
        ex.mass_to_walls += mass;
        ex.wall_frame += wall_frame * to_physical;
    }

    /// The air's force on each particle over the step (physical units, [`Self::dt`]), computed
    /// by another backend's momentum exchange, becomes the particles' loads (with the scene's
    /// own) and each body's total.
    pub fn set_air_forces(&mut self, force: Vec<DVec3>) {
        assert_eq!(force.len(), self.solid.particles.len(), "one force per particle");
        self.forces.total = self.members.bodies().map(|m| m.iter().map(|&i| force[i]).sum()).collect();
        self.forces.force = force;
        self.apply_forces();
    }

    /// Method 2's momentum_exchange stage: each wall node's momentum to the particles near it
    /// (2.127–2.128), as loads over the step.
    pub(super) fn momentum_exchange(&mut self) {
        let to_physical = self.momentum_unit();
        let dt = self.dt();
        let p = &self.solid.particles;
        let mut force = vec![DVec3::ZERO; p.len()];
        let mut total = vec![DVec3::ZERO; self.bodies.len()];
        let grid = &self.fluid.layout.grid;
        let ex = self.exchange.as_mut().expect("method 2");
        ex.changed.clear();
        // the wall nodes (momentum or mass to hand over), and each one's particles within r_e
        // — (particle, weight, its velocity in c units, its body) — found on the pool's
        // threads; then handed over in node order, as one by one (the same sums bit for bit)
        let nodes: Vec<usize> = (0..grid.len()).filter(|&node| ex.wall[node] != DVec4::ZERO).collect();
        let (sets, members) = (&ex.sets, &self.members);
        let near: Vec<Vec<(usize, f64, DVec3, usize)>> = nodes
            .par_iter()
            .with_min_len(64)
            .map(|&node| {
                let x = grid.coords(node);
                let at = [x[0] as f64, x[1] as f64, x[2] as f64];
                // a set's j-th point is its body's j-th particle
                sets.iter()
                    .zip(members.bodies())
                    .enumerate()
                    .flat_map(|(b, (s, m))| s.weights(at).map(move |(j, wj)| (m[j], wj, DVec3::from_array(s.velocities()[j]), b)))
                    .collect()
            })
            .collect();
        for (&node, weights) in nodes.iter().zip(near) {
            let w4 = ex.wall[node];
            let w = w4.truncate();
            let sum: f64 = weights.iter().map(|(_, wj, _, _)| wj).sum();
            // the wall velocity there (2.130), for the wall-frame diagnostic
            let uw = if sum > 0.0 { weights.iter().map(|(_, wj, v, _)| *wj * *v).sum::<DVec3>() / sum } else { DVec3::ZERO };
            ex.mass_to_walls += w4.w;
            ex.wall_frame += (w - uw * w4.w) * to_physical;
            if sum > 0.0 {
                for (i, wj, _, b) in weights {
                    let f = (wj / sum) * w * to_physical / dt;
                    force[i] += f;
                    total[b] += f;
                }
            } else {
                ex.walls += w * to_physical;
            }
        }
        // every node's record taken: zero for the next step
        ex.wall.par_iter_mut().with_min_len(4096).for_each(|w| *w = DVec4::ZERO);
        self.forces.force = force;
        self.forces.total = total;
        self.apply_forces();
    }
}
