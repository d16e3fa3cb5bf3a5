//! The bind groups of the FDLB stage list on the GPU: per placement of fⁿ (buffer 0 or 2) and
//! per stage of [`FDLB_STEP`], the dispatches (pipeline, bind group, threads) that
//! [`GpuFluid::record_stage`] records; made at upload and again only when a geometry table
//! outgrows its buffer ([`GpuFluid::set_geometry`]), their table-driven thread counts updated in
//! place otherwise.

use super::{GpuFluid, PIPE_ADVECT, PIPE_FACE, PIPE_GHOST, PIPE_MOMENTS, PIPE_PERIODIC, PIPE_THIN};
use crate::stages::{FDLB_STEP, RkStage, Stage, StageKind};

impl GpuFluid {
    /// The bind groups of one stage: (pipeline, bind group, threads) per dispatch, for fⁿ in
    /// buffer `cur` (0 or 2). Built once per parity at upload ([`Self::stage_groups`]).
    fn build_stage(&self, cur: usize, stage: &Stage) -> Vec<(usize, wgpu::BindGroup, u32)> {
        let (fn_, f1, fnext) = (&self.f[cur], &self.f[1], &self.f[2 - cur]);
        let k = match stage.rk {
            RkStage::First => 0,
            RkStage::Second => 1,
        };
        let params = &self.params_stage[k];
        let g = self.split.groups() as u32;
        match stage.kind {
            StageKind::MomentsCollide => {
                let (src, out) = if k == 0 { (fn_, f1) } else { (f1, fnext) };
                let bg = self.bind(
                    &self.pipelines[PIPE_MOMENTS],
                    &[(0, params), (1, &self.kind), (2, &self.mac), (3, &self.status)],
                    &[(10, src), (10 + g, fn_), (10 + 2 * g, &self.h), (10 + 3 * g, out)],
                );
                vec![(PIPE_MOMENTS, bg, self.interior)]
            }
            StageKind::Boundaries => {
                let fv = if k == 0 { fn_ } else { f1 };
                let arrays = [(10, fv), (10 + g, &self.h)];
                vec![
                    (
                        PIPE_GHOST,
                        self.bind(
                            &self.pipelines[PIPE_GHOST],
                            &[(0, &self.params_count[0]), (1, self.ghosts.0.buffer()), (2, self.ghosts.1.buffer()), (3, &self.mac)],
                            &arrays,
                        ),
                        self.ghosts.2,
                    ),
                    (
                        PIPE_FACE,
                        self.bind(&self.pipelines[PIPE_FACE], &[(0, &self.params_count[1]), (1, self.faces.0.buffer()), (3, &self.mac)], &arrays),
                        self.faces.1,
                    ),
                    (
                        PIPE_PERIODIC,
                        self.bind(&self.pipelines[PIPE_PERIODIC], &[(0, &self.params_count[2]), (4, self.periodic.0.buffer())], &[(10 + g, &self.h)]),
                        self.periodic.1,
                    ),
                ]
            }
            StageKind::Advect => {
                let out = if k == 0 { f1 } else { fnext };
                let bg = self.bind(&self.pipelines[PIPE_ADVECT], &[(0, params), (1, &self.kind)], &[(10, &self.h), (10 + g, out)]);
                let thin = self.bind(
                    &self.pipelines[PIPE_THIN],
                    &[(0, &self.thin.3[k]), (1, self.thin.0.buffer()), (2, self.thin.1.buffer())],
                    &[(10, &self.h), (10 + g, out)],
                );
                vec![(PIPE_ADVECT, bg, self.interior), (PIPE_THIN, thin, self.thin.2)]
            }
        }
    }

    /// The thread count of a table-driven dispatch (the boundary fills and the thin-wall
    /// taps: one thread per entry of their table); `None` for the lattice-wide kernels.
    fn table_count(&self, pipeline: usize) -> Option<u32> {
        match pipeline {
            PIPE_GHOST => Some(self.ghosts.2),
            PIPE_FACE => Some(self.faces.1),
            PIPE_PERIODIC => Some(self.periodic.1),
            PIPE_THIN => Some(self.thin.2),
            _ => None,
        }
    }

    /// The table-driven dispatches' thread counts set to the tables' current counts (after
    /// [`Self::set_geometry`] rewrote the tables in place).
    pub(super) fn set_dispatch_counts(&mut self) {
        let mut groups = std::mem::take(&mut self.groups);
        for (p, _, threads) in groups.iter_mut().flatten().flatten() {
            if let Some(c) = self.table_count(*p) {
                *threads = c;
            }
        }
        self.groups = groups;
    }

    /// Bind groups of every stage of [`FDLB_STEP`] for both placements of fⁿ.
    pub(super) fn stage_groups(&self) -> [Vec<Vec<(usize, wgpu::BindGroup, u32)>>; 2] {
        [0, 2].map(|cur| FDLB_STEP.iter().map(|st| self.build_stage(cur, st)).collect())
    }
}
