//! The fluid's geometry and state on the GPU: the node kinds and the boundary tables (ghost nodes with
//! their image stencils, face halos, periodic copies, thin-wall taps) built from a CPU layout —
//! once at upload, and again at every step of a coupled run whose walls move
//! ([`GpuFluid::set_geometry`], the `fluid_geometry` stage).

use super::{Entry, GpuFluid, Params};
use crate::fluid::layout::{HaloReach, NodeKind};
use crate::fluid::thin_wall::side_ghost_count;
use crate::fluid::{FaceCondition, FluidSolver};
use crate::gpu::codegen::{FaceCode, GHOST_ISOTHERMAL, periodic_reach_code};
use crate::gpu::thin_wall::{self, ThinTapEntry};

/// The geometry tables of a layout as the boundary kernels read them.
pub(super) struct Tables {
    /// Node kinds, padded to the stride with inactive nodes.
    pub kind: Vec<u32>,
    pub ghosts: Vec<Entry>,
    /// Eight (node, weight bits) image taps per ghost.
    pub images: Vec<[u32; 2]>,
    pub faces: Vec<Entry>,
    /// (destination, source, reach code, 0) of the periodic halo nodes that a stencil reads
    /// ([`crate::gpu::codegen::periodic_reach_code`]).
    pub periodic: Vec<[u32; 4]>,
    pub thin_taps: Vec<ThinTapEntry>,
    pub thin_ranges: Vec<[u32; 2]>,
}

impl Tables {
    /// The tables of solver `s`'s layout for arrays of node stride `stride`. The thin walls'
    /// side ghosts ([`crate::fluid::thin_wall`]) are ghosts at the extra nodes past the lattice
    /// (slot k at node n + k, n = the lattice's padded node count; inactive, so no other kernel
    /// touches them), filled by the same kernel; refused, with the figures, when they outgrow
    /// the room the arrays were made with ([`side_ghost_room`]).
    pub fn of(s: &FluidSolver, stride: usize) -> Result<Self, SideGhostRoom> {
        let g = &s.layout.grid;
        let n = g.len();
        let mut kind: Vec<u32> = s.layout.kind.iter().map(|k| *k as u32).collect();
        kind.resize(stride, NodeKind::Inactive as u32);
        let sides = side_ghost_count(&s.layout.thin_taps);
        if n + sides > stride {
            return Err(SideGhostRoom { needed: sides, room: stride - n });
        }
        let side_ghosts = s.layout.thin_taps.iter().flat_map(|t| &t.sides).enumerate().map(|(k, sg)| (n + k, &sg.ghost));
        let mut ghosts = Vec::new();
        let mut images: Vec<[u32; 2]> = Vec::new();
        for (node, gh) in s.layout.ghosts.iter().map(|gh| (gh.node, gh)).chain(side_ghosts) {
            assert!(gh.image.len() <= 8);
            ghosts.push(Entry {
                node: node as u32,
                code: if gh.wall_temperature.is_some() { GHOST_ISOTHERMAL } else { 0 },
                n_img: gh.image.len() as u32,
                theta: gh.wall_temperature.unwrap_or(0.0) as f32,
                ux: gh.wall_velocity[0] as f32,
                uy: gh.wall_velocity[1] as f32,
                uz: gh.wall_velocity[2] as f32,
                ratio: gh.ratio as f32,
                ..Default::default()
            });
            for j in 0..8 {
                images.push(gh.image.get(j).map(|&(k, w)| [k as u32, (w as f32).to_bits()]).unwrap_or([0, 0]));
            }
        }
        let mut faces = Vec::new();
        for fh in &s.layout.face_halos {
            let mut e = Entry { node: fh.node as u32, source: fh.source as u32, ..Default::default() };
            match &s.layout.boundaries.faces[fh.face as usize] {
                FaceCondition::Outlet => e.code = FaceCode::Outlet as u32,
                FaceCondition::Slip => e.code = FaceCode::Slip as u32 + fh.face.axis() as u32,
                FaceCondition::PressureInlet { rho, theta } => {
                    e.code = FaceCode::PressureInlet as u32;
                    e.rho = *rho as f32;
                    e.theta = *theta as f32;
                }
                FaceCondition::VelocityInlet { velocity, theta, profile } => {
                    let k = profile.factor(g, fh.face, g.coords(fh.node));
                    e.code = FaceCode::VelocityInlet as u32;
                    e.theta = *theta as f32;
                    e.ux = (k * velocity[0]) as f32;
                    e.uy = (k * velocity[1]) as f32;
                    e.uz = (k * velocity[2]) as f32;
                }
                _ => unreachable!("face halo of a periodic or wall face"),
            }
            faces.push(e);
        }
        let periodic = s
            .layout
            .periodic
            .iter()
            .filter(|r| r.reach != HaloReach::Unread)
            .flat_map(|r| (0..r.len).map(move |k| [(r.dst + k) as u32, (r.src + k) as u32, periodic_reach_code(r.reach), 0]))
            .collect();
        let (thin_taps, thin_ranges) = thin_wall::entries(&s.layout);
        Ok(Tables { kind, ghosts, images, faces, periodic, thin_taps, thin_ranges })
    }

    /// Threads of the ghost (with the side ghosts), face and periodic fills.
    pub fn counts(&self) -> [u32; 3] {
        [self.ghosts.len() as u32, self.faces.len() as u32, self.periodic.len() as u32]
    }
}

impl GpuFluid {
    /// Replaces the geometry (node kinds and boundary tables) with that of `s`, a solver of the
    /// same lattice whose walls moved: the `fluid_geometry` stage of a coupled step on the GPU,
    /// the tables built on the CPU from the bodies' walls (the particles' positions come back
    /// each step; the populations only on steps where nodes change side,
    /// [`Self::upload_state`]). Only the span of node kinds that changed goes up (none on most
    /// steps); the boundary tables (ghost depths and wall velocities change every step) are
    /// rewritten in their buffers, and the fills' thread counts with them. New buffers and bind
    /// groups are made only when a table outgrows its buffer (which holds half as much again as
    /// when it was made, `gpu::growing::GrowingBuffer`; counted by
    /// [`Self::geometry_rebinds`]), so that the steady state of a coupled run makes none. The
    /// populations are untouched.
    /// Refused, changing nothing, when the new walls need more side ghosts than the arrays have
    /// room for ([`SideGhostRoom`]).
    pub fn set_geometry(&mut self, s: &FluidSolver) -> Result<(), SideGhostRoom> {
        assert_eq!(s.layout.grid.len(), self.n_nodes, "a layout of the same lattice");
        let t = Tables::of(s, self.stride)?;
        let changed = t.kind.iter().zip(&self.kind_host).position(|(a, b)| a != b);
        if let Some(first) = changed {
            let last = t.kind.iter().zip(&self.kind_host).rposition(|(a, b)| a != b).expect("a first one, so a last one");
            self.queue.write_buffer(&self.kind, (4 * first) as u64, bytemuck::cast_slice(&t.kind[first..=last]));
            self.kind_host[first..=last].copy_from_slice(&t.kind[first..=last]);
        }
        let (device, queue) = (&self.device, &self.queue);
        let mut remade = false;
        remade |= self.ghosts.0.write(device, queue, bytemuck::cast_slice(&t.ghosts));
        remade |= self.ghosts.1.write(device, queue, bytemuck::cast_slice(&t.images));
        remade |= self.faces.0.write(device, queue, bytemuck::cast_slice(&t.faces));
        remade |= self.periodic.0.write(device, queue, bytemuck::cast_slice(&t.periodic));
        let thin_remade =
            self.thin.0.write(device, queue, bytemuck::cast_slice(&t.thin_taps)) | self.thin.1.write(device, queue, bytemuck::cast_slice(&t.thin_ranges));
        remade |= thin_remade;
        // the fills' thread counts: in their parameters and in the recorded dispatches
        let counts = t.counts();
        let old = [self.ghosts.2, self.faces.1, self.periodic.1];
        for k in 0..3 {
            if counts[k] != old[k] {
                self.queue.write_buffer(&self.params_count[k], 0, bytemuck::bytes_of(&Params { count: counts[k], ..self.base }));
            }
        }
        (self.ghosts.2, self.faces.1, self.periodic.1) = (counts[0], counts[1], counts[2]);
        let thin_count = t.thin_ranges.len() as u32;
        if thin_count != self.thin.2 {
            for (k, stage) in [1, 2].into_iter().enumerate() {
                self.queue.write_buffer(&self.thin.3[k], 0, bytemuck::bytes_of(&Params { stage, count: thin_count, ..self.base }));
            }
            self.thin.2 = thin_count;
        }
        if remade {
            self.geometry_rebinds += 1;
            self.groups = self.stage_groups();
        } else {
            self.set_dispatch_counts();
        }
        // the face-flux record's thin-wall targets follow the new taps
        self.refresh_thin_fluxes(s, thin_remade);
        Ok(())
    }

    /// Buffers and bind groups made for a coupled run's per-step work since the upload, the
    /// first ones included: the boundary tables' and the thin-wall flux tables' buffers (more
    /// only when a table outgrew its buffer), method 1's traction kernels' buffers and bind
    /// groups, the node-list (gather, scatter) and totals kernels' buffers and bind groups, and
    /// the staging buffers of the gather's, the totals' and the piece forces' reads. The stage
    /// bind groups remade with the tables are [`Self::geometry_rebinds`].
    pub fn step_objects_made(&self) -> u64 {
        let tables = [&self.ghosts.0, &self.ghosts.1, &self.faces.0, &self.periodic.0, &self.thin.0, &self.thin.1];
        let staging = [&self.node_readback, &self.totals_readback, &self.piece_readback];
        tables.iter().map(|b| b.made()).sum::<u64>()
            + self.face_fluxes.as_ref().map_or(0, |ff| ff.thin_tables_made())
            + self.traction_objects_made
            + self.state_objects_made
            + staging.iter().map(|r| r.made()).sum::<u64>()
    }

    /// Writes the populations of `s` (a solver of the same lattice) as the state fⁿ.
    pub fn upload_state(&mut self, s: &FluidSolver) {
        assert_eq!(s.layout.grid.len(), self.n_nodes, "a solver of the same lattice");
        self.queue.write_buffer(&self.f[self.cur], 0, bytemuck::cast_slice(&state_array(s, self.stride)));
    }
}

/// The populations of `s` as the GPU holds them: f32, value v of a node at `v · stride + node`.
pub(super) fn state_array(s: &FluidSolver, stride: usize) -> Vec<f32> {
    let nv = s.eq.values_per_node();
    let mut f = vec![0f32; nv * stride];
    let mut vals = vec![0.0; nv];
    for node in 0..s.layout.grid.len() {
        s.pop.gather(&s.f, node, &mut vals);
        for (v, x) in vals.iter().enumerate() {
            f[v * stride + node] = *x as f32;
        }
    }
    f
}

/// The thin walls of a new geometry need more side ghosts than the GPU fluid's arrays hold nodes
/// for past the lattice (sized when the fluid went up: twice what its walls needed then, at
/// least a 32nd of the lattice or 256 nodes).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SideGhostRoom {
    pub needed: usize,
    pub room: usize,
}

impl std::fmt::Display for SideGhostRoom {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "the thin walls need {} side ghosts, more than the {} nodes the GPU fluid's arrays hold past the lattice (sized when the fluid went up)",
            self.needed, self.room
        )
    }
}

/// The extra nodes past the lattice the GPU arrays hold for the thin walls' side ghosts, whose
/// number changes as bodies move: twice what `s` needs now, and at least a 32nd of the lattice
/// (a closed 2D glottis at 128² needs a few hundred) or 256.
pub(super) fn side_ghost_room(s: &FluidSolver) -> usize {
    (2 * side_ghost_count(&s.layout.thin_taps)).max(s.layout.grid.len() / 32).max(256)
}
