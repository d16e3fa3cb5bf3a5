//! The boundary fill of the FDLB solver: before every Runge–Kutta stage, the ghost nodes inside
//! walls and obstacles, the thin walls' side ghosts, the inlet/outlet/slip face halos and the
//! periodic halos take their values from the fluid by the conditions of [`super::boundary`].
//!
//! Each list is filled in two passes: every node's values are found on the pool's threads (a
//! ghost or a halo reads fluid or interior nodes only, never another entry of its list), then
//! written row by row. A ghost's image stencil nodes share their moments and f − f⁰, found once
//! per fill. Each node's values come from the same operations as one by one: bit for bit.

use super::boundary::FaceCondition;
use super::equilibrium::{Equilibrium, MACRO_FIELDS, Macro};
use super::layout::{Ghost, Layout};
use super::storage::{RowBlocked, Storage, copy_runs_parallel, shift_of};
use super::timestep::StepParams;
use rayon::prelude::*;

/// Ghosts per task of the pool: a ghost costs about a microsecond (D3Q39: 8 image nodes'
/// equilibria and populations).
const PAR_GHOSTS: usize = 64;

/// Node state arrays of one Runge–Kutta stage: populations f, the advected field
/// h = (1 − A/τ) f + (A/τ) f⁰, and the macroscopic fields.
pub struct StageFields<'a, S: Storage = f64> {
    pub f: &'a mut [S],
    pub h: &'a mut [S],
    pub mac: &'a mut [f64],
    /// h of the thin walls' side ghosts ([`super::thin_wall`]), `values_per_node` per slot.
    pub side_h: &'a mut Vec<f64>,
    /// Scratch kept between fills ([`GhostScratch`]).
    pub ghost_scratch: &'a mut GhostScratch<S>,
    /// The storage shift of each population value (empty when unshifted:
    /// [`super::storage::Storage`]).
    pub shift: &'a [f64],
    pub pop: RowBlocked,
    pub mac_layout: RowBlocked,
}

/// Fills ghost, inlet/outlet and periodic halo nodes of `fields` (seed §2.3 boundaries, the
/// conditions of [`super::boundary`]). Fluid nodes must already hold their moments and equilibria.
pub fn fill_boundaries<S: Storage>(layout: &Layout, eq: &Equilibrium, fields: &mut StageFields<S>, p: StepParams) {
    let k_eq = p.a / p.tau;
    let nv = eq.values_per_node();

    // Ghost nodes inside walls and obstacles, and the thin walls' side ghosts. A ghost reads
    // fluid nodes only (its image stencil) and writes only itself. Each image node's state
    // (its moments and f − f⁰) is found once — neighbouring ghosts share most of their image
    // nodes —, then every ghost's values from those, on the pool's threads (each by the same
    // operations as one by one: the same values bit for bit), then written row by row.
    let sides: Vec<&Ghost> = layout.thin_taps.iter().flat_map(|t| &t.sides).map(|sg| &sg.ghost).collect();
    let mut scratch = std::mem::take(fields.ghost_scratch);
    scratch.image_states(eq, fields, layout.ghosts.iter().chain(sides.iter().copied()), layout.grid.len());
    let mut values = std::mem::replace(&mut scratch.values, NodeValues::new());
    values.clear(nv);
    {
        let (states, slot, shift) = (&scratch.states, &scratch.slot, fields.shift);
        values.fill(layout.ghosts.iter().map(|g| g.node), eq, |s, g, pops, mac| {
            let mg = ghost_state(&layout.ghosts[g], states, slot, &mut s.neq);
            node_values(eq, &mg, &s.neq, k_eq, &mut s.w, &mut s.fe, shift, pops, mac);
        });
    }
    values.write(fields);
    // the side ghosts: h only (the advection is all that reads them), each into its own slot
    fields.side_h.resize(sides.len() * nv, 0.0);
    {
        let (states, slot) = (&scratch.states, &scratch.slot);
        fields.side_h.par_chunks_mut(nv.max(1)).zip(&sides).with_min_len(PAR_GHOSTS).for_each_init(
            || Scratch::new(eq),
            |s, (out, g)| {
                let mg = ghost_state(g, states, slot, &mut s.neq);
                eq.feq_into(&mg, &mut s.w, &mut s.fe);
                for (v, (e, n)) in out.iter_mut().zip(s.fe.iter().zip(&s.neq)) {
                    *v = e + (1.0 - k_eq) * n;
                }
            },
        );
    }

    // Inlet and outlet halos: each from its source, an interior node no halo is (the first
    // interior node on its line normal to the face; a slip face's mirror node), the same way:
    // found on the pool's threads, then written row by row.
    values.clear(nv);
    {
        let read: &StageFields<S> = fields;
        values.fill(layout.face_halos.iter().map(|h| h.node), eq, |s, k, pops, mac| {
            let h = &layout.face_halos[k];
            let src = h.source;
            match &layout.boundaries.faces[h.face as usize] {
                FaceCondition::Outlet => {
                    let (f, hv) = pops.split_at_mut(nv);
                    read.pop.gather_raw(read.f, src, f);
                    read.pop.gather_raw(read.h, src, hv);
                    read.mac_layout.gather(read.mac, src, mac);
                }
                FaceCondition::Slip => {
                    // populations reflected across the face, the normal velocity negated
                    let axis = h.face.axis();
                    let perm = eq.mirror_permutation(axis);
                    let (f, hv) = pops.split_at_mut(nv);
                    let base = read.pop.index(src, 0);
                    for (a, out) in [(&*read.f, f), (&*read.h, hv)] {
                        for (o, &p) in out.iter_mut().zip(perm) {
                            *o = a[base + p * read.pop.px];
                        }
                    }
                    read.mac_layout.gather(read.mac, src, mac);
                    mac[1 + axis] = -mac[1 + axis];
                }
                FaceCondition::PressureInlet { rho, theta } => {
                    let ms = read_macro(read, src);
                    non_equilibrium(eq, read, src, &mut s.w, &mut s.fe, &mut s.neq);
                    let m = Macro { rho: *rho, u: ms.u, theta: *theta };
                    node_values(eq, &m, &s.neq, k_eq, &mut s.w, &mut s.fe, read.shift, pops, mac);
                }
                FaceCondition::VelocityInlet { velocity, theta, profile } => {
                    let ms = read_macro(read, src);
                    non_equilibrium(eq, read, src, &mut s.w, &mut s.fe, &mut s.neq);
                    let k = profile.factor(&layout.grid, h.face, layout.grid.coords(h.node));
                    let m = Macro { rho: ms.rho, u: velocity.map(|v| k * v), theta: *theta };
                    node_values(eq, &m, &s.neq, k_eq, &mut s.w, &mut s.fe, read.shift, pops, mac);
                }
                FaceCondition::Periodic | FaceCondition::Wall { .. } => unreachable!("not a face halo"),
            }
        });
    }
    values.write(fields);
    scratch.values = values;
    *fields.ghost_scratch = scratch;

    // Periodic halos last, so that they also copy ghosts that lie next to a periodic face: only
    // the values of h that the advection reads there (`Equilibrium::values_read_at`). f and the
    // macroscopic fields are read at fluid nodes only (the moments pass, the ghosts' images, the
    // face halos' sources, every observation), so their periodic halos are not copied.
    copy_runs_parallel(fields.pop, fields.h, &layout.periodic, |r| eq.values_read_at(r.reach));
}

/// The state of ghost `g` (the macroscopic values; its non-equilibrium part into `neq`): the
/// image point's, interpolated from fluid nodes, with the wall velocity (and an isothermal wall's
/// temperature) extrapolated through the wall and the image pressure kept. `states`: each image
/// node's moments and f − f⁰ ([`GhostScratch::image_states`]) at `slot[node]`.
fn ghost_state(g: &Ghost, states: &[f64], slot: &[u32], neq: &mut [f64]) -> Macro {
    let nv = neq.len();
    let mut m = [0.0; MACRO_FIELDS];
    neq.iter_mut().for_each(|v| *v = 0.0);
    for &(k, wk) in &g.image {
        let at = slot[k] as usize * (MACRO_FIELDS + nv);
        let (mk, nk) = states[at..at + MACRO_FIELDS + nv].split_at(MACRO_FIELDS);
        for (v, x) in m.iter_mut().zip(mk) {
            *v += wk * x;
        }
        for i in 0..nv {
            neq[i] += wk * nk[i];
        }
    }
    let r = g.ratio;
    let uw = g.wall_velocity;
    let u = [uw[0] + r * (m[1] - uw[0]), uw[1] + r * (m[2] - uw[1]), uw[2] + r * (m[3] - uw[2])];
    let theta = match g.wall_temperature {
        Some(tw) => tw + r * (m[4] - tw),
        None => m[4],
    };
    // Zero normal pressure gradient: the ghost keeps the image pressure at its own temperature.
    Macro { rho: m[0] * m[4] / theta, u, theta }
}

/// What a boundary fill keeps between calls (the solver holds it): the image nodes' slots and
/// states, and the ghosts' values before they are written.
#[derive(Clone, Debug)]
pub struct GhostScratch<S = f64> {
    /// Slot of each padded node in `states` (`u32::MAX`: not an image node of this fill).
    slot: Vec<u32>,
    /// The image nodes, in the order of their slots.
    nodes: Vec<usize>,
    /// Per slot: ρ, u, θ, then f − f⁰ (`nv` values).
    states: Vec<f64>,
    /// The values of the ghosts, then of the face halos, before they are written.
    values: NodeValues<S>,
}

impl<S: Storage> Default for GhostScratch<S> {
    fn default() -> Self {
        GhostScratch { slot: Vec::new(), nodes: Vec::new(), states: Vec::new(), values: NodeValues::new() }
    }
}

impl<S: Storage> GhostScratch<S> {
    /// The moments and f − f⁰ of every image node of `ghosts`, once each (on the pool's threads).
    fn image_states<'g>(&mut self, eq: &Equilibrium, fields: &StageFields<S>, ghosts: impl Iterator<Item = &'g Ghost>, nodes: usize) {
        for &k in &self.nodes {
            self.slot[k] = u32::MAX;
        }
        self.slot.resize(nodes, u32::MAX);
        self.nodes.clear();
        for g in ghosts {
            for &(k, _) in &g.image {
                if self.slot[k] == u32::MAX {
                    self.slot[k] = self.nodes.len() as u32;
                    self.nodes.push(k);
                }
            }
        }
        let nv = eq.values_per_node();
        let width = MACRO_FIELDS + nv;
        self.states.resize(self.nodes.len() * width, 0.0);
        self.states.par_chunks_mut(width).zip(&self.nodes).with_min_len(PAR_GHOSTS).for_each_init(
            || Scratch::new(eq),
            |s, (out, &k)| {
                let mk = read_macro(fields, k);
                out[..MACRO_FIELDS].copy_from_slice(&[mk.rho, mk.u[0], mk.u[1], mk.u[2], mk.theta]);
                eq.feq_into(&mk, &mut s.w, &mut s.fe);
                fields.pop.gather_populations(fields.f, k, fields.shift, &mut s.fk);
                for (o, (f, e)) in out[MACRO_FIELDS..].iter_mut().zip(s.fk.iter().zip(&s.fe)) {
                    *o = f - e;
                }
            },
        );
    }
}

/// A boundary fill's per-thread scratch: the equilibrium's shell weights, one node's
/// equilibrium, populations and non-equilibrium part.
struct Scratch {
    w: Vec<f64>,
    fe: Vec<f64>,
    fk: Vec<f64>,
    neq: Vec<f64>,
}

impl Scratch {
    fn new(eq: &Equilibrium) -> Self {
        let nv = eq.values_per_node();
        Scratch { w: vec![0.0; eq.set.shells.len()], fe: vec![0.0; nv], fk: vec![0.0; nv], neq: vec![0.0; nv] }
    }
}

/// A node's values as a fill writes them for macro `m` and non-equilibrium part `neq`:
/// f = f⁰ + neq and h = f + (A/τ)(f⁰ − f) = f⁰ + (1 − A/τ) neq into `pops` (`nv` each, stored as
/// `S` with the per-value shifts `shift`), ρ, u, θ into `mac`.
#[allow(clippy::too_many_arguments)]
fn node_values<S: Storage>(eq: &Equilibrium, m: &Macro, neq: &[f64], k_eq: f64, w: &mut [f64], fe: &mut [f64], shift: &[f64], pops: &mut [S], mac: &mut [f64]) {
    let nv = neq.len();
    eq.feq_into(m, w, fe);
    let (f, h) = pops.split_at_mut(nv);
    for i in 0..nv {
        let s = shift_of(shift, i);
        f[i] = S::encode(fe[i] + neq[i], s);
        h[i] = S::encode(fe[i] + (1.0 - k_eq) * neq[i], s);
    }
    mac.copy_from_slice(&[m.rho, m.u[0], m.u[1], m.u[2], m.theta]);
}

/// The values a fill writes into a list of distinct nodes (the ghosts, or the face halos), found
/// first on the pool's threads — each node's from nodes that are not on the list — and then
/// written: per node 2·nv population values (f, then h; as stored) and the five macroscopic
/// fields.
#[derive(Clone, Debug)]
struct NodeValues<S> {
    nodes: Vec<usize>,
    pops: Vec<S>,
    mac: Vec<f64>,
    nv: usize,
}

impl<S: Storage> NodeValues<S> {
    fn new() -> Self {
        NodeValues { nodes: Vec::new(), pops: Vec::new(), mac: Vec::new(), nv: 0 }
    }

    /// Empty, for nodes of `nv` population values each (the buffers kept: [`Self::fill`]
    /// overwrites every entry it keeps).
    fn clear(&mut self, nv: usize) {
        self.nv = nv;
        self.nodes.clear();
    }

    /// Entry k (node `nodes[k]`) from `value(scratch, k, pops, mac)`, on the pool's threads.
    fn fill(&mut self, nodes: impl Iterator<Item = usize>, eq: &Equilibrium, value: impl Fn(&mut Scratch, usize, &mut [S], &mut [f64]) + Sync) {
        self.nodes.extend(nodes);
        let count = self.nodes.len();
        // grown only (the ghosts' and the halos' fills alternate): entries past `count` are stale
        if self.pops.len() < count * 2 * self.nv {
            self.pops.resize(count * 2 * self.nv, S::default());
        }
        if self.mac.len() < count * MACRO_FIELDS {
            self.mac.resize(count * MACRO_FIELDS, 0.0);
        }
        if count == 0 {
            return;
        }
        self.pops[..count * 2 * self.nv]
            .par_chunks_mut(2 * self.nv)
            .zip(self.mac[..count * MACRO_FIELDS].par_chunks_mut(MACRO_FIELDS))
            .enumerate()
            .with_min_len(PAR_GHOSTS)
            .for_each_init(|| Scratch::new(eq), |s, (k, (pops, mac))| value(s, k, pops, mac));
    }

    /// Writes every entry into its node: the rows of the padded grid on the pool's threads, a
    /// row's nodes value by value (neighbouring nodes share cache lines); one by one when the
    /// list is not in node order (layouts list ghosts and halos in node order).
    fn write(&self, fields: &mut StageFields<S>) {
        let (nv, nodes) = (self.nv, &self.nodes);
        if nodes.is_empty() {
            return;
        }
        if !nodes.is_sorted() {
            for (k, &node) in nodes.iter().enumerate() {
                let (f, h) = self.pops[k * 2 * nv..(k + 1) * 2 * nv].split_at(nv);
                fields.pop.scatter_raw(fields.f, node, f);
                fields.pop.scatter_raw(fields.h, node, h);
                fields.mac_layout.scatter(fields.mac, node, &self.mac[k * MACRO_FIELDS..(k + 1) * MACRO_FIELDS]);
            }
            return;
        }
        let px = fields.pop.px;
        let rows = fields
            .f
            .par_chunks_mut(fields.pop.row_len())
            .zip(fields.h.par_chunks_mut(fields.pop.row_len()))
            .zip(fields.mac.par_chunks_mut(fields.mac_layout.row_len()));
        rows.enumerate().for_each(|(r, ((f, h), mac))| {
            let lo = nodes.partition_point(|&n| n < r * px);
            let hi = nodes.partition_point(|&n| n < (r + 1) * px);
            for v in 0..nv {
                for k in lo..hi {
                    let x = v * px + nodes[k] - r * px;
                    f[x] = self.pops[k * 2 * nv + v];
                    h[x] = self.pops[k * 2 * nv + nv + v];
                }
            }
            for c in 0..MACRO_FIELDS {
                for k in lo..hi {
                    mac[c * px + nodes[k] - r * px] = self.mac[k * MACRO_FIELDS + c];
                }
            }
        });
    }
}

fn read_macro<S: Storage>(fields: &StageFields<S>, node: usize) -> Macro {
    let mut m = [0.0; MACRO_FIELDS];
    fields.mac_layout.gather(fields.mac, node, &mut m);
    Macro { rho: m[0], u: [m[1], m[2], m[3]], theta: m[4] }
}

/// f − f⁰ of `node` into `neq`.
fn non_equilibrium<S: Storage>(eq: &Equilibrium, fields: &StageFields<S>, node: usize, w: &mut [f64], fe: &mut [f64], neq: &mut [f64]) {
    eq.feq_into(&read_macro(fields, node), w, fe);
    fields.pop.gather_populations(fields.f, node, fields.shift, neq);
    for (n, e) in neq.iter_mut().zip(fe.iter()) {
        *n -= e;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fluid::boundary::{Boundaries, Face};
    use crate::fluid::{FluidSolver, GasModel, Grid, VelocitySet, VelocitySetKind, timestep};

    /// The fill writes each ghost's and face halo's values whatever the order of the layout's
    /// lists: in node order (as layouts list them) it writes rows on the pool's threads, else one
    /// by one — the same arrays bit for bit, on a state that is not at rest (a disc in a channel
    /// with a pressure inlet, an outlet, a slip face and a wall, diatomic D2Q21, after 30 steps),
    /// and each ghost's values equal to the sum over its image stencil done here in full.
    #[test]
    fn the_fill_writes_the_same_values_in_any_order_of_its_lists() {
        use crate::fluid::{Obstacle, Shape};
        let eq = Equilibrium::new(VelocitySet::new(VelocitySetKind::D2q21), GasModel::Diatomic);
        let l1 = eq.set.max_l1_speed();
        let params = timestep::choose(0.02, 0.6, l1, None, timestep::DEFAULT_COURANT_SAFETY).unwrap();
        let mut b = Boundaries::periodic();
        b.faces[Face::XMin as usize] = FaceCondition::PressureInlet { rho: 1.02, theta: 0.6 };
        b.faces[Face::XMax as usize] = FaceCondition::Outlet;
        b.faces[Face::YMin as usize] = FaceCondition::Slip;
        b.faces[Face::YMax as usize] = FaceCondition::Wall { velocity: [0.01, 0.0, 0.0], temperature: None };
        let disc = Obstacle { shape: Shape::Cylinder { center: [9.3, 7.6, 0.0], radius: 3.4 }, velocity: [0.0; 3], temperature: Some(0.62) };
        let mut s = FluidSolver::new(eq.clone(), Grid::new(2, [28, 16, 1]), b, &[disc], params, |_| Macro { rho: 1.0, u: [0.0; 3], theta: 0.6 });
        s.run(30).unwrap();
        let layout = s.layout.clone();
        assert!(layout.ghosts.len() > 20 && layout.face_halos.len() > 40, "{} ghosts, {} face halos", layout.ghosts.len(), layout.face_halos.len());
        let (f1, _, h, mac) = s.stage_arrays();
        // every ghost's and face halo's values NaN before the fill: it must write them all
        let written: Vec<usize> = layout.ghosts.iter().map(|g| g.node).chain(layout.face_halos.iter().map(|h| h.node)).collect();
        let (mut f0, mut h0, mut mac0) = (f1.to_vec(), h.to_vec(), mac.to_vec());
        let nv = eq.values_per_node();
        for &node in &written {
            s.pop.scatter(&mut f0, node, &vec![f64::NAN; nv]);
            s.pop.scatter(&mut h0, node, &vec![f64::NAN; nv]);
            s.macro_layout.scatter(&mut mac0, node, &[f64::NAN; MACRO_FIELDS]);
        }
        let fill = |layout: &Layout| {
            let (mut f, mut h, mut mac) = (f0.clone(), h0.clone(), mac0.clone());
            let (mut side_h, mut scratch) = (Vec::new(), GhostScratch::default());
            let mut fields = StageFields {
                f: &mut f,
                h: &mut h,
                mac: &mut mac,
                side_h: &mut side_h,
                ghost_scratch: &mut scratch,
                shift: &[],
                pop: s.pop,
                mac_layout: s.macro_layout,
            };
            fill_boundaries(layout, &eq, &mut fields, params);
            (f, h, mac)
        };
        let sorted = fill(&layout);
        let mut reversed = layout.clone();
        reversed.ghosts.reverse();
        reversed.face_halos.reverse();
        let bits = |(f, h, m): &(Vec<f64>, Vec<f64>, Vec<f64>)| f.iter().chain(h).chain(m).map(|x| x.to_bits()).collect::<Vec<u64>>();
        assert!(bits(&sorted) == bits(&fill(&reversed)), "the two orders wrote different values");
        assert!(sorted.0.iter().chain(&sorted.1).chain(&sorted.2).all(|x| !x.is_nan()), "a ghost or face halo was not written");
        // the fill before this one (the last step's) wrote the same values from the same state
        assert!(bits(&sorted) == bits(&(f1.to_vec(), h.to_vec(), mac.to_vec())), "not the values the step's own fill wrote");
        // one ghost in full: its macro and f from the image stencil's moments and f − f⁰
        let (pop, ml) = (s.pop, s.macro_layout);
        let mut worst: f64 = 0.0;
        for g in &layout.ghosts {
            let (mut m, mut neq) = ([0.0; MACRO_FIELDS], vec![0.0; nv]);
            let (mut w, mut fe, mut fk) = (vec![0.0; eq.set.shells.len()], vec![0.0; nv], vec![0.0; nv]);
            for &(k, wk) in &g.image {
                let mut mk = [0.0; MACRO_FIELDS];
                ml.gather(mac, k, &mut mk);
                m.iter_mut().zip(mk).for_each(|(a, b)| *a += wk * b);
                eq.feq_into(&Macro { rho: mk[0], u: [mk[1], mk[2], mk[3]], theta: mk[4] }, &mut w, &mut fe);
                pop.gather(f1, k, &mut fk);
                neq.iter_mut().zip(fk.iter().zip(&fe)).for_each(|(n, (a, b))| *n += wk * (a - b));
            }
            let r = g.ratio;
            let theta = g.wall_temperature.map_or(m[4], |tw| tw + r * (m[4] - tw));
            let u: [f64; 3] = std::array::from_fn(|a| g.wall_velocity[a] + r * (m[1 + a] - g.wall_velocity[a]));
            eq.feq_into(&Macro { rho: m[0] * m[4] / theta, u, theta }, &mut w, &mut fe);
            pop.gather(&sorted.0, g.node, &mut fk);
            for i in 0..nv {
                worst = worst.max((fk[i] - (fe[i] + neq[i])).abs());
            }
        }
        assert!(worst == 0.0, "a ghost's f differs from its stencil's by {worst:e}");
    }
}
