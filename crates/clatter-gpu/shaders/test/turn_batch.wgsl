// A turning boundary's pose (turn.wgsl) on a batch of (axis, rate, centre, elapsed time), for
// tests/turn.rs. Compiled after the simulation prelude and helpers (src/turn.rs), which
// declare `params` (only `params.one` is read).

struct TurnQuery {
    // xyz the unit axis, w the rate (rad/s).
    axis_rate: vec4<f32>,
    // xyz the centre, w unused.
    centre: vec4<f32>,
    // The elapsed time u as (hi, lo), then the angle to use when `angle_given` (zw).
    u: vec4<f32>,
}

struct TurnAnswer {
    q: vec4<f32>,
    // xyz the translation, w the angle turn_angle found.
    t: vec4<f32>,
    // (sin, cos) of the query's zw.x, then zw.
    sc: vec4<f32>,
}

@group(0) @binding(90) var<storage, read> turn_queries: array<TurnQuery>;
@group(0) @binding(91) var<storage, read_write> turn_answers: array<TurnAnswer>;

@compute @workgroup_size(64)
fn turn_batch(@builtin(global_invocation_id) id: vec3<u32>) {
    let k = id.x;
    if k >= arrayLength(&turn_queries) {
        return;
    }
    let q = turn_queries[k];
    let angle = turn_angle(q.axis_rate.w, q.u.xy);
    let pose = turn_pose(q.axis_rate.xyz, q.centre.xyz, angle);
    let sc = turn_sin_cos(q.u.z);
    turn_answers[k] = TurnAnswer(pose.q, vec4<f32>(pose.t, angle), vec4<f32>(sc, 0.0, 0.0));
}
