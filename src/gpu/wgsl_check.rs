//! Test support: every WGSL module the crate compiles — hand-written (`shaders/`) and generated
//! — is validated by naga, and each Rust mirror of a WGSL struct is compared with the struct
//! naga lays out: the same named members at the same byte offsets with the same sizes, and the
//! same total size (padding members, named `_…` or `pad…`, are free to differ in name).

use naga::proc::Layouter;
use naga::valid::{Capabilities, ValidationFlags, Validator};

/// One field of a Rust mirror: name, byte offset, size.
pub(crate) type Field = (&'static str, usize, usize);

/// The fields of a `#[repr(C)]` struct, with their offsets and sizes:
/// `mirror!(Params { n_nodes, px })`.
macro_rules! mirror {
    ($t:ty { $($f:ident),* $(,)? }) => {{
        fn size_of_field<T, F>(_: fn(&T) -> &F) -> usize {
            std::mem::size_of::<F>()
        }
        (std::mem::size_of::<$t>(), vec![$((stringify!($f), std::mem::offset_of!($t, $f), size_of_field(|s: &$t| &s.$f))),*])
    }};
}
pub(crate) use mirror;

/// Parses and validates `src` (named `name` in messages).
pub(crate) fn validate(name: &str, src: &str) -> naga::Module {
    let module = naga::front::wgsl::parse_str(src).unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(src)));
    Validator::new(ValidationFlags::all(), Capabilities::all()).validate(&module).unwrap_or_else(|e| panic!("{name}: {e:?}"));
    module
}

fn padding(name: &str) -> bool {
    name.starts_with('_') || name.starts_with("pad")
}

/// Compares the Rust mirror `(size, fields)` with the WGSL struct `wgsl_struct` of `src`.
pub(crate) fn check_mirror(name: &str, src: &str, wgsl_struct: &str, (size, fields): (usize, Vec<Field>)) {
    let module = validate(name, src);
    let mut layouter = Layouter::default();
    layouter.update(module.to_ctx()).expect("layout of a validated module");
    let (members, span) = module
        .types
        .iter()
        .find_map(|(_, ty)| match &ty.inner {
            naga::TypeInner::Struct { members, span } if ty.name.as_deref() == Some(wgsl_struct) => Some((members.clone(), *span)),
            _ => None,
        })
        .unwrap_or_else(|| panic!("{name}: no struct {wgsl_struct}"));
    assert_eq!(size, span as usize, "{name}: Rust {wgsl_struct} is {size} bytes, WGSL {span}");
    let wgsl: Vec<(String, usize, usize)> = members
        .iter()
        .filter_map(|m| {
            let n = m.name.clone().unwrap_or_default();
            (!padding(&n)).then(|| (n, m.offset as usize, layouter[m.ty].size as usize))
        })
        .collect();
    let rust: Vec<(String, usize, usize)> = fields.iter().filter(|f| !padding(f.0)).map(|&(n, o, s)| (n.to_string(), o, s)).collect();
    assert_eq!(rust, wgsl, "{name}: {wgsl_struct}: Rust (name, offset, size) ≠ WGSL");
}

/// Compares a bind group layout's `(uniform?, read-only?)` per binding — what
/// `gpu::context::buffer_layout` is given — with the buffers `src` declares in bind group
/// `group`: the same bindings 0, 1, … in order, each a uniform where the layout says so, else a
/// storage buffer read-only exactly where the layout says so.
pub(crate) fn check_bindings(name: &str, src: &str, group: u32, kinds: &[(bool, bool)]) {
    let module = validate(name, src);
    let mut declared: Vec<(u32, (bool, bool))> = module
        .global_variables
        .iter()
        .filter_map(|(_, g)| {
            let b = g.binding.as_ref().filter(|b| b.group == group)?;
            let kind = match g.space {
                naga::AddressSpace::Uniform => (true, true),
                naga::AddressSpace::Storage { access } => (false, !access.contains(naga::StorageAccess::STORE)),
                _ => return None,
            };
            Some((b.binding, kind))
        })
        .collect();
    declared.sort_by_key(|d| d.0);
    let ours: Vec<(u32, (bool, bool))> = kinds.iter().enumerate().map(|(k, &kind)| (k as u32, kind)).collect();
    assert_eq!(ours, declared, "{name}: group {group}: the layout's (binding, (uniform?, read-only?)) ≠ the shader's");
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fluid::{Equilibrium, GasModel, VelocitySet, VelocitySetKind};
    use crate::gpu::codegen::{self, Split};

    /// Every module of the crate, hand-written and generated (both velocity sets, both gases,
    /// whole and split bindings), parses and validates.
    #[test]
    fn every_wgsl_module_validates() {
        let mut n = 0;
        for (name, src) in [
            ("shaders/copy.wgsl", include_str!("../../shaders/copy.wgsl").to_string()),
            ("shaders/coupling.wgsl", include_str!("../../shaders/coupling.wgsl").to_string()),
            ("shaders/marching_cubes.wgsl", include_str!("../../shaders/marching_cubes.wgsl").to_string()),
            ("shaders/level_set_grid.wgsl", crate::gpu::fold_surface::SHADER.to_string()),
            ("shaders/slice.wgsl", crate::gpu::slice::SHADER.to_string()),
            ("shaders/tracers.wgsl (+ hash.wgsl)", crate::gpu::tracers::SHADER.to_string()),
            ("shaders/solid.wgsl + solid_implicit.wgsl", crate::gpu::solid::SHADER.to_string()),
            ("shaders/solid_contact.wgsl", include_str!("../../shaders/solid_contact.wgsl").to_string()),
            ("lattice_gas (shaders/lattice_gas.wgsl + generated)", crate::gpu::lattice_gas_codegen::shader()),
        ] {
            validate(name, &src);
            n += 1;
        }
        for kind in [VelocitySetKind::D2q21, VelocitySetKind::D3q39] {
            for gas in [GasModel::Monatomic, GasModel::Diatomic] {
                let eq = Equilibrium::new(VelocitySet::new(kind), gas);
                let nv = eq.values_per_node();
                for split in [Split::whole(nv), Split { nv, per_binding: 16 }] {
                    for (name, src) in [
                        ("moments_collide", codegen::moments_collide(&eq, split)),
                        ("advect", codegen::advect(&eq, split)),
                        ("thin_wall", codegen::thin_wall(&eq, split)),
                        ("face_fluxes", codegen::face_fluxes(&eq, split)),
                        ("thin_wall_fluxes", codegen::thin_wall_fluxes(&eq, split)),
                        ("boundaries", codegen::boundaries(&eq, split)),
                        ("probes", codegen::probes(&eq, split)),
                        ("gather_populations", codegen::gather_populations(&eq, split)),
                        ("scatter_populations", codegen::scatter_populations(&eq, split)),
                        ("totals", codegen::totals(&eq, split)),
                        ("traction", codegen::traction(&eq, split)),
                    ] {
                        validate(&format!("{name} {kind:?} {gas:?} {split:?}"), &src);
                        // no run-time indexing of const arrays (naga + lavapipe copy them per
                        // access, DESIGN §7): the only arrays are local accumulators
                        assert!(!src.contains("const C"), "{name}");
                        n += 1;
                    }
                }
            }
        }
        assert_eq!(n, 9 + 2 * 2 * 2 * 11);
    }

    /// A mirror that differs from its shader is caught (the check can fail).
    #[test]
    fn a_mirror_that_differs_is_caught() {
        #[repr(C)]
        #[allow(dead_code)]
        struct Wrong {
            a: u32,
            b: f32,
        }
        let src = "struct S { a: u32, c: f32 };\n@group(0) @binding(0) var<uniform> s: S;\n@compute @workgroup_size(1) fn main() { _ = s.a; }";
        let r = std::panic::catch_unwind(|| check_mirror("test", src, "S", mirror!(Wrong { a, b })));
        assert!(r.is_err(), "a field named differently must fail");
        #[repr(C)]
        #[allow(dead_code)]
        struct Right {
            a: u32,
            c: f32,
        }
        check_mirror("test", src, "S", mirror!(Right { a, c }));
    }
}
