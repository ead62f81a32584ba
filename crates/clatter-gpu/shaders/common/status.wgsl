// Dispatch helpers every simulation kernel shares: thread indexing, the pipeline's stop
// flag and workgroup-aggregated status counters. Compiled after the generated prelude
// (src/layout.rs `wgsl_prelude`: records, constants, group-0 bindings).

// The linear index of a thread in a (possibly 2D) dispatch of WG-wide workgroups.
fn thread_index(wid: vec3<u32>, nwg: vec3<u32>, lid: u32) -> u32 {
    return (wid.y * nwg.x + wid.x) * WG + lid;
}

// Whether the pipeline is stopped (pair overflow, a non-finite body, or a rebuild due in a
// lean step): nothing runs until the host acts, so the state stays at the start of the step
// that could not be done. A health alarm (health.wgsl) stops it after the step it checked.
fn halted() -> bool {
    return atomicLoad(&status[ST_OVERFLOW]) != 0u || atomicLoad(&status[ST_BAD_BODY]) != NONE
        || atomicLoad(&status[ST_STALL]) != 0u || atomicLoad(&status[ST_HEALTH]) != 0u
        || atomicLoad(&status[ST_MESH_FULL]) != 0u;
}

var<workgroup> wg_flag: u32;
var<workgroup> wg_sum: atomic<u32>;

// `halted()` read once per workgroup (one global atomic load instead of one per thread) and
// handed to every thread as a uniform value, so a whole workgroup returns together and the
// barriers after it stay in uniform control flow. Also clears the workgroup's sum for
// `add_status_wg`. Call first thing, from every thread.
fn halted_wg(lid: u32) -> bool {
    if lid == 0u {
        wg_flag = select(0u, 1u, halted());
        atomicStore(&wg_sum, 0u);
    }
    return workgroupUniformLoad(&wg_flag) != 0u;
}

// Adds each thread's `k` to status word `word` with one global atomic per workgroup (not
// one per thread: millions of threads on one address serialise). Every thread of the
// workgroup must call it, after `halted_wg`.
fn add_status_wg(lid: u32, word: u32, k: u32) {
    if k != 0u {
        atomicAdd(&wg_sum, k);
    }
    workgroupBarrier();
    if lid == 0u {
        let total = atomicLoad(&wg_sum);
        if total != 0u {
            atomicAdd(&status[word], total);
        }
    }
}

// Periodic boundaries (crates/clatter/src/periodic.rs, the same operations): `x` wrapped into
// the box along the periodic axes (params.periodic_len > 0).
fn periodic_wrap(x: vec3<f32>) -> vec3<f32> {
    var out = x;
    for (var k = 0u; k < 3u; k++) {
        let len = params.periodic_len[k];
        if len > 0.0 {
            let lo = params.periodic_min[k];
            if out[k] >= lo + len {
                out[k] -= len;
            } else if out[k] < lo {
                out[k] += len;
            }
        }
    }
    return out;
}

// The shortest periodic image of the difference `d` of two wrapped positions.
fn periodic_nearest(d: vec3<f32>) -> vec3<f32> {
    var out = d;
    for (var k = 0u; k < 3u; k++) {
        let len = params.periodic_len[k];
        if len > 0.0 {
            if out[k] > 0.5 * len {
                out[k] -= len;
            } else if out[k] < -0.5 * len {
                out[k] += len;
            }
        }
    }
    return out;
}

// Where body j is seen from body i: its nearest image.
fn image_of(i: u32, j: u32) -> vec3<f32> {
    let xi = bodies[i].position.xyz;
    return xi + periodic_nearest(bodies[j].position.xyz - xi);
}
