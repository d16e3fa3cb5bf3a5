// Draws the GPU tracers of a GPU-stepped fluid as streaks, straight from the storage buffer the
// tracer kernel's positions are copied into each frame (src/render/gpu_tracers.rs): no readback.
// The buffer holds the positions now (tracers 0..n) and a frame ago (n..2n), one vec4 each
// (lattice coordinates, w = generation bits). Each streak is one line of the mesh, whose vertex
// position carries (tracer index, end: 0 = a frame ago, 1 = now, 0). A tracer that jumped more
// than two cells (born again at the inlet) draws nothing this frame; a slow one draws a dash a
// third of a cell long. Colour: sky blue when slow to warm
// white when fast, the CPU tracers' map (render::tracers::tracer_colour), t = displacement over
// `scale.x` (cells per frame). A Bevy material shader (its imports and #{MATERIAL_BIND_GROUP} go
// through Bevy's preprocessor, so it is not in the naga check of gpu::wgsl_check): compiled and
// drawn by tests/plugin.rs `gpu_tracers_are_advected_and_drawn_on_the_device` on lavapipe.

#import bevy_pbr::mesh_functions::{get_world_from_local, mesh_position_local_to_clip}

@group(#{MATERIAL_BIND_GROUP}) @binding(0) var<storage, read> tracers: array<vec4<f32>>;
@group(#{MATERIAL_BIND_GROUP}) @binding(1) var<uniform> scale: vec4<f32>;

struct Vertex {
    @builtin(instance_index) instance_index: u32,
    @location(0) position: vec3<f32>,
};

struct VertexOutput {
    @builtin(position) clip_position: vec4<f32>,
    @location(0) color: vec4<f32>,
};

@vertex
fn vertex(v: Vertex) -> VertexOutput {
    let n = arrayLength(&tracers) / 2u;
    let k = min(u32(v.position.x), n - 1u);
    let now = tracers[k].xyz;
    let before = tracers[n + k].xyz;
    let d = length(now - before);
    var p = now;
    if (v.position.y < 0.5 && d <= 2.0) {
        // at least a third of a cell long, so that slow tracers show (as the CPU tracers do)
        var dir = vec3<f32>(0.0, 1.0, 0.0);
        if (d > 1e-6) {
            dir = (before - now) / d;
        }
        p = now + dir * max(d, 1.0 / 3.0);
    }
    let t = clamp(d / max(scale.x, 1e-6), 0.0, 1.0);
    var out: VertexOutput;
    out.clip_position = mesh_position_local_to_clip(get_world_from_local(v.instance_index), vec4<f32>(p, 1.0));
    out.color = vec4<f32>(0.35 + 0.65 * t, 0.75 + 0.2 * t, 1.0 - 0.55 * t, 1.0);
    return out;
}

@fragment
fn fragment(in: VertexOutput) -> @location(0) vec4<f32> {
    return in.color;
}
