// Batch narrow-phase queries (src/narrow.rs): one invocation per query record, writing one
// Manifold. Concatenated after common.wgsl and narrow.wgsl. A pair query reads what the pair
// remembers in `memory` (narrow.wgsl nrw_mem_in: the contact hint and the margin's bits) and
// leaves there what it remembers after (nrw_mem_out).

// A query: shape indices and mode in `shapes` (x = shape a / the body's shape, y = shape b,
// z = 0 for a shape pair, 1 for a wall plane). Pair: a at (xa, qa), b at (xb, qb).
// Plane: xa = (normal, offset), the shape at (xb, qb).
struct NarrowQuery {
    xa: vec4<f32>,
    qa: vec4<f32>,
    xb: vec4<f32>,
    qb: vec4<f32>,
    shapes: vec4<u32>,
}

@group(0) @binding(0) var<storage, read> queries: array<NarrowQuery>;
@group(0) @binding(1) var<storage, read_write> manifolds: array<Manifold>;
@group(0) @binding(2) var<storage, read_write> memory: array<vec2<u32>>;

const BATCH_WG: u32 = 64u;

@compute @workgroup_size(64)
fn narrow_batch(
    @builtin(workgroup_id) wid: vec3<u32>,
    @builtin(num_workgroups) nwg: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
) {
    let i = (wid.y * nwg.x + wid.x) * BATCH_WG + lid;
    if i >= arrayLength(&queries) {
        return;
    }
    let qr = queries[i];
    if qr.shapes.z == 1u {
        manifolds[i] = collide_plane(qr.xa.xyz, qr.xa.w, qr.shapes.x, qr.xb.xyz, qr.qb);
    } else {
        nrw_mem_in = memory[i];
        manifolds[i] = collide(qr.shapes.x, qr.xa.xyz, qr.qa, qr.shapes.y, qr.xb.xyz, qr.qb);
        memory[i] = nrw_mem_out;
    }
}
