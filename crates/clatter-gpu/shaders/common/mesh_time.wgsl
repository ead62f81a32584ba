// The triangle-mesh boundaries' clock (src/mesh.rs), shared by every kernel: per boundary,
// `u = t - start` as an unevaluated sum of two f32 (hi, lo) in the `mesh` buffer, which the
// CPU keeps in f64 (a rotation's angle follows from it: turn.wgsl). `end_step` advances them,
// `prepare` notes the pose of a rebuild (for the Verlet check), the contact and integrate
// kernels read them.

// `hi + lo` of `a + b` to about 2^-48 (Knuth's two-sum, then renormalised). `params.one`
// (1.0, unknown to the compiler) keeps the error terms from being simplified away.
fn ds_add(a: vec2<f32>, b: vec2<f32>) -> vec2<f32> {
    let s = (a.x + b.x) * params.one;
    let v = (s - a.x) * params.one;
    let e = ((a.x - (s - v) * params.one) + (b.x - v)) + (a.y + b.y);
    let hi = (s + e) * params.one;
    let lo = e - (hi - s) * params.one;
    return vec2<f32>(hi, lo);
}

// a < b for normalised sums.
fn ds_lt(a: vec2<f32>, b: vec2<f32>) -> bool {
    return a.x < b.x || (a.x == b.x && a.y < b.y);
}

// a > 0.
fn ds_positive(a: vec2<f32>) -> bool {
    return a.x > 0.0 || (a.x == 0.0 && a.y > 0.0);
}

// The first word of boundary b's clock.
fn mesh_clock(b: u32) -> u32 {
    return MESH_GLOBAL + MESH_BSTATE * b;
}

fn mesh_word_f(k: u32) -> f32 {
    return bitcast<f32>(mesh[k]);
}

fn mesh_ds(k: u32) -> vec2<f32> {
    return vec2<f32>(mesh_word_f(k), mesh_word_f(k + 1u));
}

fn mesh_set_ds(k: u32, v: vec2<f32>) {
    mesh[k] = bitcast<u32>(v.x);
    mesh[k + 1u] = bitcast<u32>(v.y);
}

// How long boundary b's motion has run when `t - start` is u: the CPU's
// `Boundary::elapsed`, `clamp(u, 0, end - start)` rounded to f32.
fn mesh_elapsed(b: u32, u: vec2<f32>) -> f32 {
    let d = mesh_ds(mesh_clock(b) + 7u);
    if !ds_positive(u) {
        return 0.0;
    }
    if !ds_lt(u, d) {
        return d.x;
    }
    return u.x;
}

// `t - start` of boundary b at the current step.
fn mesh_u(b: u32) -> vec2<f32> {
    return mesh_ds(mesh_clock(b));
}

// `t - start` of boundary b after this step (the time the Verlet check looks at).
fn mesh_u_next(b: u32) -> vec2<f32> {
    return ds_add(mesh_u(b), vec2<f32>(params.dt, 0.0));
}

// The clocks one step on (end_step; the CPU's `time += dt`).
fn mesh_advance() {
    for (var b = 0u; b < params.num_boundaries; b++) {
        let at = mesh_clock(b);
        mesh_set_ds(at, mesh_u_next(b));
    }
}

// The end of a step (`end_step`, health.wgsl `end_step_gate`): counts it and moves the
// clocks on, unless the pipeline stopped during it.
fn count_step() {
    if !halted() {
        atomicAdd(&status[ST_STEPS], 1u);
        mesh_advance();
    }
}

// A rebuild at this step (prepare): the step count and each boundary's elapsed time.
fn mesh_note_rebuild() {
    if params.num_boundaries == 0u {
        return;
    }
    mesh[0] = atomicLoad(&status[ST_STEPS]);
    for (var b = 0u; b < params.num_boundaries; b++) {
        mesh[mesh_clock(b) + 4u] = bitcast<u32>(mesh_elapsed(b, mesh_u(b)));
    }
}
