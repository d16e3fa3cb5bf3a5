// Draws the bodies' surfaces that the level-set and marching-cubes kernels wrote on the device
// (src/render/gpu_fold_mesh.rs, src/gpu/fold_surface.rs): no readback. The mesh has three
// vertices per triangle of room in the buffers, each carrying its vertex's index in its
// position's x; a vertex of a triangle past the counter (this frame's surface is smaller than
// the room) collapses to one point, so that triangle draws nothing. Positions are in the level
// sets' coordinates (the entity's transform takes them to scene units); the normal's w is the
// body's index, which picks its colour (render::fold_mesh::BODY_COLOURS, linear RGBA). Shading:
// the colour times (0.35 + 0.65 |n·l|) for the fixed light direction l (world), two-sided.
// A Bevy material shader (its imports and #{MATERIAL_BIND_GROUP} go through Bevy's
// preprocessor, so it is not in the naga check of gpu::wgsl_check): compiled and drawn by
// tests/plugin.rs `the_fold_mesh_made_on_the_gpu_draws_the_cpu_meshs_folds` on lavapipe.

#import bevy_pbr::mesh_functions::{get_world_from_local, mesh_position_local_to_clip, mesh_normal_local_to_world}

struct FoldColours {
    body: array<vec4<f32>, 4>,
    // the light's direction (world, unit), .w unused
    light: vec4<f32>,
};

@group(#{MATERIAL_BIND_GROUP}) @binding(0) var<storage, read> positions: array<vec4<f32>>;
@group(#{MATERIAL_BIND_GROUP}) @binding(1) var<storage, read> normals: array<vec4<f32>>;
@group(#{MATERIAL_BIND_GROUP}) @binding(2) var<storage, read> counter: array<u32>;
@group(#{MATERIAL_BIND_GROUP}) @binding(3) var<uniform> colours: FoldColours;

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
    let k = u32(v.position.x);
    let room = arrayLength(&positions) / 3u;
    var out: VertexOutput;
    if (k / 3u >= min(counter[0], room)) {
        out.clip_position = vec4<f32>(0.0, 0.0, 0.0, 1.0);
        out.color = vec4<f32>(0.0);
        return out;
    }
    let world_from_local = get_world_from_local(v.instance_index);
    let nw = normals[k];
    let m = mesh_normal_local_to_world(nw.xyz, v.instance_index);
    let len = length(m);
    // a vertex where ∇L vanished has no normal: lit as if facing the light
    let n = select(colours.light.xyz, m / len, len > 0.0);
    let shade = 0.35 + 0.65 * abs(dot(n, colours.light.xyz));
    let c = colours.body[u32(nw.w) % 4u];
    out.clip_position = mesh_position_local_to_clip(world_from_local, vec4<f32>(positions[k].xyz, 1.0));
    out.color = vec4<f32>(c.rgb * shade, c.a);
    return out;
}

@fragment
fn fragment(in: VertexOutput) -> @location(0) vec4<f32> {
    return in.color;
}
