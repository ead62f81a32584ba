// The contact law (law.wgsl) on a batch of contact states, for tests/law.rs. Compiled after
// the contract's records, common.wgsl and law.wgsl (src/law/mod.rs).

struct LawQuery {
    context: PairContext,
    normal: vec3<f32>,
    count: u32,
    points: array<vec4<f32>, 4>,
    a_position: vec4<f32>,
    a_velocity: vec4<f32>,
    a_omega: vec4<f32>,
    b_position: vec4<f32>,
    b_velocity: vec4<f32>,
    b_omega: vec4<f32>,
    hist: vec4<f32>,
}

struct LawAnswer {
    force: ContactForce,
    hist: vec4<f32>,
}

@group(0) @binding(0) var<storage, read> queries: array<LawQuery>;
@group(0) @binding(1) var<storage, read_write> answers: array<LawAnswer>;

@compute @workgroup_size(64)
fn law_batch(@builtin(global_invocation_id) id: vec3<u32>) {
    let k = id.x;
    if k >= arrayLength(&queries) {
        return;
    }
    let q = queries[k];
    let m = Manifold(q.normal, q.count, q.points);
    let a = BodyMotion(q.a_position.xyz, q.a_velocity.xyz, q.a_omega.xyz);
    let b = BodyMotion(q.b_position.xyz, q.b_velocity.xyz, q.b_omega.xyz);
    let r = contact_force(q.context, m, a, b, q.hist);
    answers[k] = LawAnswer(r.force, r.hist);
}
