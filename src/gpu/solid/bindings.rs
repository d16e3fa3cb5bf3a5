//! The bindings and kernels of shaders/solid.wgsl (+ solid_implicit.wgsl) by type instead of by string: one [`Buf`] per
//! binding, named as the shader names its variable, and one [`Kernel`] per entry point. A test
//! parses the shader with naga and checks every binding's name, group, index and access and
//! every entry point against these lists, so a renamed or reordered binding fails the tests
//! instead of binding the wrong buffer.

use std::ops::Index;

/// A buffer of the MPS solid on the GPU: the shader variable of the same name (snake case).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Buf {
    Params,
    Offs,
    Nbr,
    Rev,
    BondR0,
    BondStiffness,
    BondGrad,
    Cstiff,
    Pinfo,
    Pos,
    Vel,
    Spin,
    Quat,
    Load,
    Rot,
    Qmat,
    TorqueG,
    Force,
    Torque,
    ExtraForce,
    ExtraTorque,
    LinX,
    LinV,
    Theta,
    Jinv,
    Lambda,
    Cg,
    Precond,
    Partials,
    Scalars,
    PatchIndex,
    PatchInverse,
}

impl Buf {
    pub const COUNT: usize = 32;

    /// The shader's variable name.
    pub fn name(self) -> &'static str {
        match self {
            Buf::Params => "P",
            Buf::Offs => "offs",
            Buf::Nbr => "nbr",
            Buf::Rev => "rev",
            Buf::BondR0 => "bond_r0",
            Buf::BondStiffness => "bond_stiffness",
            Buf::BondGrad => "bond_grad",
            Buf::Cstiff => "cstiff",
            Buf::Pinfo => "pinfo",
            Buf::Pos => "pos",
            Buf::Vel => "vel",
            Buf::Spin => "spin",
            Buf::Quat => "quat",
            Buf::Load => "load",
            Buf::Rot => "rot",
            Buf::Qmat => "qmat",
            Buf::TorqueG => "torque_g",
            Buf::Force => "force",
            Buf::Torque => "torque",
            Buf::ExtraForce => "extra_force",
            Buf::ExtraTorque => "extra_torque",
            Buf::LinX => "lin_x",
            Buf::LinV => "lin_v",
            Buf::Theta => "theta",
            Buf::Jinv => "jinv",
            Buf::Lambda => "lambda",
            Buf::Cg => "cg",
            Buf::Precond => "precond",
            Buf::Partials => "partials",
            Buf::Scalars => "scalars",
            Buf::PatchIndex => "patch_index",
            Buf::PatchInverse => "patch_inverse",
        }
    }
}

/// (buffer, read-only) per binding of group 0 (state, discretisation, forces).
pub(super) const G0: [(Buf, bool); 21] = [
    (Buf::Params, true),
    (Buf::Offs, true),
    (Buf::Nbr, true),
    (Buf::Rev, true),
    (Buf::BondR0, true),
    (Buf::BondStiffness, true),
    (Buf::BondGrad, true),
    (Buf::Cstiff, true),
    (Buf::Pinfo, true),
    (Buf::Pos, false),
    (Buf::Vel, false),
    (Buf::Spin, false),
    (Buf::Quat, false),
    (Buf::Load, true),
    (Buf::Rot, false),
    (Buf::Qmat, false),
    (Buf::TorqueG, false),
    (Buf::Force, false),
    (Buf::Torque, false),
    (Buf::ExtraForce, false),
    (Buf::ExtraTorque, false),
];

/// (buffer, read-only) per binding of group 1 (the implicit method's solve).
pub(super) const G1: [(Buf, bool); 11] = [
    (Buf::LinX, false),
    (Buf::LinV, false),
    (Buf::Theta, false),
    (Buf::Jinv, false),
    (Buf::Lambda, false),
    (Buf::Cg, false),
    (Buf::Precond, true),
    (Buf::Partials, false),
    (Buf::Scalars, false),
    (Buf::PatchIndex, true),
    (Buf::PatchInverse, true),
];

/// Every buffer, indexed by [`Buf`].
pub(super) struct Buffers(Vec<wgpu::Buffer>);

impl Buffers {
    /// From one buffer per [`Buf`] (`make` is called in binding order, group 0 then 1).
    pub fn new(mut make: impl FnMut(Buf) -> wgpu::Buffer) -> Self {
        let mut slots: Vec<Option<wgpu::Buffer>> = vec![None; Buf::COUNT];
        for (b, _) in G0.iter().chain(&G1) {
            slots[*b as usize] = Some(make(*b));
        }
        Buffers(slots.into_iter().enumerate().map(|(k, b)| b.unwrap_or_else(|| panic!("buffer {k} is in no bind group"))).collect())
    }
}

impl Index<Buf> for Buffers {
    type Output = wgpu::Buffer;
    fn index(&self, b: Buf) -> &wgpu::Buffer {
        &self.0[b as usize]
    }
}

/// An entry point of shaders/solid.wgsl + solid_implicit.wgsl.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Kernel {
    RotationMatrices,
    StrainStressFull,
    StrainStressLinear,
    BondForcesFull,
    BondForcesLinear,
    IntegrateExplicit,
    SolveRotations,
    RotationIncrements,
    ChainLambda,
    ChainForces,
    CgRhs,
    CgApply,
    CgDots,
    CgSum,
    CgUpdate,
    CgDirection,
    CgKeep,
    IntegrateImplicit,
    AngularVelocity,
    PrepareKv,
    CgPatches,
    CgFirstDirection,
    CgUpdateResidual,
    CoarseRestrict,
    CoarseSolve,
    CoarseProlong,
}

impl Kernel {
    pub const ALL: [Kernel; 26] = [
        Kernel::RotationMatrices,
        Kernel::StrainStressFull,
        Kernel::StrainStressLinear,
        Kernel::BondForcesFull,
        Kernel::BondForcesLinear,
        Kernel::IntegrateExplicit,
        Kernel::SolveRotations,
        Kernel::RotationIncrements,
        Kernel::ChainLambda,
        Kernel::ChainForces,
        Kernel::CgRhs,
        Kernel::CgApply,
        Kernel::CgDots,
        Kernel::CgSum,
        Kernel::CgUpdate,
        Kernel::CgDirection,
        Kernel::CgKeep,
        Kernel::IntegrateImplicit,
        Kernel::AngularVelocity,
        Kernel::PrepareKv,
        Kernel::CgPatches,
        Kernel::CgFirstDirection,
        Kernel::CgUpdateResidual,
        Kernel::CoarseRestrict,
        Kernel::CoarseSolve,
        Kernel::CoarseProlong,
    ];

    /// The WGSL entry point.
    pub fn entry(self) -> &'static str {
        match self {
            Kernel::RotationMatrices => "rotation_matrices",
            Kernel::StrainStressFull => "strain_stress_full",
            Kernel::StrainStressLinear => "strain_stress_linear",
            Kernel::BondForcesFull => "bond_forces_full",
            Kernel::BondForcesLinear => "bond_forces_linear",
            Kernel::IntegrateExplicit => "integrate_explicit",
            Kernel::SolveRotations => "solve_rotations",
            Kernel::RotationIncrements => "rotation_increments",
            Kernel::ChainLambda => "chain_lambda",
            Kernel::ChainForces => "chain_forces",
            Kernel::CgRhs => "cg_rhs",
            Kernel::CgApply => "cg_apply",
            Kernel::CgDots => "cg_dots",
            Kernel::CgSum => "cg_sum",
            Kernel::CgUpdate => "cg_update",
            Kernel::CgDirection => "cg_direction",
            Kernel::CgKeep => "cg_keep",
            Kernel::IntegrateImplicit => "integrate_implicit",
            Kernel::AngularVelocity => "angular_velocity",
            Kernel::PrepareKv => "prepare_kv",
            Kernel::CgPatches => "cg_patches",
            Kernel::CgFirstDirection => "cg_first_direction",
            Kernel::CgUpdateResidual => "cg_update_residual",
            Kernel::CoarseRestrict => "coarse_restrict",
            Kernel::CoarseSolve => "coarse_solve",
            Kernel::CoarseProlong => "coarse_prolong",
        }
    }
}

/// One pipeline per [`Kernel`].
pub(super) struct Pipelines(Vec<wgpu::ComputePipeline>);

impl Pipelines {
    pub fn new(device: &wgpu::Device, module: &wgpu::ShaderModule, layout: &wgpu::PipelineLayout) -> Self {
        let mut map = crate::gpu::context::compute_pipelines(device, module, layout, &Kernel::ALL.map(Kernel::entry));
        Pipelines(Kernel::ALL.iter().map(|k| map.remove(k.entry()).expect("one pipeline per entry point")).collect())
    }
}

impl Index<Kernel> for Pipelines {
    type Output = wgpu::ComputePipeline;
    fn index(&self, k: Kernel) -> &wgpu::ComputePipeline {
        &self.0[k as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every binding of shaders/solid.wgsl is the [`Buf`] of the same name at the same group
    /// and index with the same access, and the entry points are exactly [`Kernel::ALL`].
    #[test]
    fn the_bindings_and_kernels_match_the_shader() {
        let module = crate::gpu::wgsl_check::validate("shaders/solid.wgsl + solid_implicit.wgsl", super::super::SHADER);
        let groups: [&[(Buf, bool)]; 2] = [&G0, &G1];
        let mut seen = 0;
        for (_, var) in module.global_variables.iter() {
            let Some(rb) = &var.binding else { continue };
            let (buf, read_only) = groups[rb.group as usize][rb.binding as usize];
            let name = var.name.as_deref().unwrap_or("");
            assert_eq!(name, buf.name(), "group {} binding {}", rb.group, rb.binding);
            let ro = match var.space {
                naga::AddressSpace::Uniform => true,
                naga::AddressSpace::Storage { access } => !access.contains(naga::StorageAccess::STORE),
                other => panic!("{name}: address space {other:?}"),
            };
            assert_eq!(ro, read_only, "{name}: read-only");
            seen += 1;
        }
        assert_eq!(seen, G0.len() + G1.len(), "every listed buffer is bound in the shader");
        let mut entries: Vec<&str> = module.entry_points.iter().map(|e| e.name.as_str()).collect();
        let mut ours: Vec<&str> = Kernel::ALL.iter().map(|k| k.entry()).collect();
        entries.sort();
        ours.sort();
        assert_eq!(entries, ours);
        // the patch smoother's workgroup array holds the unknowns of the largest patch the host
        // uploads
        let (_, c) = module.constants.iter().find(|(_, c)| c.name.as_deref() == Some("PATCH_UNKNOWNS")).expect("PATCH_UNKNOWNS in the shader");
        match module.global_expressions[c.init] {
            naga::Expression::Literal(naga::Literal::U32(v)) => assert_eq!(v as usize, 3 * super::super::PATCH_MAX_PARTICLES),
            ref e => panic!("PATCH_UNKNOWNS = {e:?}"),
        }
    }
}
