// Dispatch helpers every simulation kernel shares: thread indexing, the pipeline's stop
// flag and workgroup-aggregated status counters. Compiled after the generated prelude
// (src/layout.rs `wgsl_prelude`: records, constants, group-0 bindings).

// The linear index of a thread in a (possibly 2D) dispatch of WG-wide workgroups.
fn thread_index(wid: vec3<u32>, nwg: vec3<u32>, lid: u32) -> u32 {
    return (wid.y * nwg.x + wid.x) * WG + lid;
}

// Dealt dispatches (contacts_sat, contacts_full, integrate; the sphere scenes' contacts):
// lavapipe and llvmpipe hand each of their `params.deal` threads one run of consecutive
// workgroups of a dispatch (a real GPU, deal 1, takes workgroups as they come). A list in
// order (pairs by class, bodies by cell, whose cost runs with their kind and with their
// height in a pile) would give one thread the costly part. So the list is cut into chunks
// of DEAL_CHUNK consecutive items (one NVIDIA warp, four of lavapipe's 8-lane subgroups:
// neighbours still run together), and chunk q goes to run q mod deal: every run gets every
// deal-th chunk. With deal 1 this is thread_index. Only which thread computes an item
// changes, never its result.
const DEAL_CHUNK: u32 = 32u;

// Workgroups per run for `count` items: ceil(count / (deal * WG)).
fn dealt_per_run(count: u32) -> u32 {
    let per = max(params.deal, 1u) * WG;
    return count / per + select(0u, 1u, count % per != 0u);
}

// Workgroups of a dealt dispatch over `count` items (a multiple of the runs).
fn dealt_groups(count: u32) -> u32 {
    return dealt_per_run(count) * max(params.deal, 1u);
}

// The item (of `count`) a thread of a dealt dispatch of at least dealt_groups(count)
// workgroups runs; `count` or more: none.
fn dealt_item(wid: vec3<u32>, nwg: vec3<u32>, lid: u32, count: u32) -> u32 {
    let runs = max(params.deal, 1u);
    let per_run = dealt_per_run(count);
    let g = wid.y * nwg.x + wid.x;
    if g >= per_run * runs {
        return count;
    }
    // Run `g / per_run`, its workgroup `g % per_run`, the chunk within that workgroup.
    let p = (g % per_run) * (WG / DEAL_CHUNK) + lid / DEAL_CHUNK;
    return (p * runs + g / per_run) * DEAL_CHUNK + lid % DEAL_CHUNK;
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

// `x` (a pair) wrapped into the box (the CPU's `Periodic::wrap_f64`).
fn periodic_wrap_ds(x: Ds3) -> Ds3 {
    var shift = vec3<f32>(0.0);
    for (var k = 0u; k < 3u; k++) {
        let len = params.periodic_len[k];
        if len > 0.0 {
            let lo = params.periodic_min[k];
            if x.hi[k] >= lo + len {
                shift[k] = -len;
            } else if x.hi[k] < lo {
                shift[k] = len;
            }
        }
    }
    if all(shift == vec3<f32>(0.0)) {
        return x;
    }
    return ds3_add(x, Ds3(shift, vec3<f32>(0.0)));
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

// Where body j is seen from body i: its nearest image, at the high parts of the positions
// (the broad phase's rounded positions; the contact stages use `offset_of`).
fn image_of(i: u32, j: u32) -> vec3<f32> {
    let xi = bodies[i].position.xyz;
    return xi + periodic_nearest(bodies[j].position.xyz - xi);
}

// Precise positions (crates/clatter/src/precise.rs, the twin of these functions, op for
// op): a body's centre is the double-single pair `position.xyz + position_lo.xyz` (hi the
// nearest f32, lo the rest, on the grid `ds_snap` keeps), which the CPU stores as the f64
// `hi + lo`. Relative geometry is taken from differences of the pairs, rounded to f32 only
// after subtracting.
struct Ds3 {
    hi: vec3<f32>,
    lo: vec3<f32>,
}

// `a + b` to about 2^-48 per component (mesh_time.wgsl's `ds_add` on vectors).
fn ds3_add(a: Ds3, b: Ds3) -> Ds3 {
    let s = (a.hi + b.hi) * params.one;
    let v = (s - a.hi) * params.one;
    let e = ((a.hi - (s - v) * params.one) + (b.hi - v)) + (a.lo + b.lo);
    let hi = (s + e) * params.one;
    let lo = e - (hi - s) * params.one;
    return Ds3(hi, lo);
}

// The pair with its low part rounded to a multiple of 2^-48 of the high part's binade, then
// renormalised (hi the nearest f32 of the sum): at most 49 significant bits, so exactly the
// f64 the CPU stores (precise.rs `snap`). Below |hi| = 2^-78 the low part is dropped.
fn ds_snap(p: Ds3) -> Ds3 {
    let e = (bitcast<vec3<u32>>(p.hi) >> vec3<u32>(23u)) & vec3<u32>(0xffu);
    let keep = e > vec3<u32>(48u);
    let eq = select(vec3<u32>(49u), e, keep);
    let q = bitcast<vec3<f32>>((eq - vec3<u32>(48u)) << vec3<u32>(23u));
    let inv = bitcast<vec3<f32>>((vec3<u32>(302u) - eq) << vec3<u32>(23u));
    let ls = select(vec3<f32>(0.0), round(p.lo * inv) * q, keep);
    let hs = (p.hi + ls) * params.one;
    let lo = ls - (hs - p.hi) * params.one;
    return Ds3(hs, lo);
}

fn ds3_neg(a: Ds3) -> Ds3 {
    return Ds3(-a.hi, -a.lo);
}

// Body i's centre as a pair.
fn body_ds(i: u32) -> Ds3 {
    return Ds3(bodies[i].position.xyz, bodies[i].position_lo.xyz);
}

// `d` moved to its shortest periodic image (the CPU's `Periodic::nearest_f64`).
fn periodic_nearest_ds(d: Ds3) -> Ds3 {
    var shift = vec3<f32>(0.0);
    for (var k = 0u; k < 3u; k++) {
        let len = params.periodic_len[k];
        if len > 0.0 {
            if d.hi[k] > 0.5 * len {
                shift[k] = -len;
            } else if d.hi[k] < -0.5 * len {
                shift[k] = len;
            }
        }
    }
    if all(shift == vec3<f32>(0.0)) {
        return d;
    }
    return ds3_add(d, Ds3(shift, vec3<f32>(0.0)));
}

// Where body j (its nearest image) is seen from body i: `x_j - x_i` of the pairs, then
// rounded to f32 (the CPU's `World::offset_of`).
fn offset_of(i: u32, j: u32) -> vec3<f32> {
    return periodic_nearest_ds(ds3_add(body_ds(j), ds3_neg(body_ds(i)))).hi;
}

// A world point `x` seen from body i (`x - x_i`; the CPU's `World::relative_to`).
fn relative_to(i: u32, x: vec3<f32>) -> vec3<f32> {
    return ds3_add(Ds3(x, vec3<f32>(0.0)), ds3_neg(body_ds(i))).hi;
}

// `a b` as an unevaluated sum (product, error), exactly: Dekker's product with Veltkamp's
// split (no fused multiply-add needed; `params.one` keeps the split from being simplified).
fn two_prod(a: f32, b: f32) -> vec2<f32> {
    let p = a * b;
    let ca = 4097.0 * a;
    let ah = ca - (ca - a) * params.one;
    let al = a - ah;
    let cb = 4097.0 * b;
    let bh = cb - (cb - b) * params.one;
    let bl = b - bh;
    let e = ((ah * bh - p) + ah * bl + al * bh) + al * bl;
    return vec2<f32>(p, e);
}

// The offset of the plane `n . x = d` as seen from body i: `d - n . x_i` as a pair (offset,
// rest), with `n . hi` summed exactly (precise.rs `plane_offset`); the rest is added to the
// depths of the contact found with the offset.
fn plane_offset_from(i: u32, n: vec3<f32>, d: f32) -> vec2<f32> {
    let b = bodies[i];
    var s = vec2<f32>(d, 0.0);
    for (var k = 0u; k < 3u; k++) {
        let p = two_prod(n[k], b.position[k]);
        s = ds_add(s, -p);
    }
    return ds_add(s, vec2<f32>(-dot(n, b.position_lo.xyz), 0.0));
}
