// Stage **contacts** for scenes with polyhedra, in two passes (most candidate pairs in a
// pile do not touch, and a GPU thread group waits for its slowest pair): `contacts_sat`
// proves pairs apart cheaply (bounding spheres, separating axes, the pair's hint first) and
// lists the rest in `new_pairs` (free outside a rebuild); `contacts_size` sizes the second
// pass; `contacts_full` runs `pair_contact` (contacts.wgsl) on the list. Each pair writes
// only its own slots, so the list's order does not change results.

var<workgroup> wg_base: u32;

// The pairs contacts_full runs are listed by class within each workgroup's share of the
// list, so that neighbouring threads (one subgroup, which runs in lockstep) mostly run the
// same shapes down the same path (full test, remembered face, remembered edge contact),
// instead of every shape pair and path a subgroup's lanes happen to hold, one after the
// other. A class is the path and the two bodies' shape indices (capped at SPLIT_SHAPES - 1).
// Only which thread computes a pair changes, never its result.
const SPLIT_SHAPES: u32 = 6u;
const SPLIT_CLASSES: u32 = 3u * SPLIT_SHAPES * SPLIT_SHAPES;
var<workgroup> wg_class_count: array<atomic<u32>, SPLIT_CLASSES>;
var<workgroup> wg_class_at: array<u32, SPLIT_CLASSES>;

// The class of candidate pair c (see SPLIT_CLASSES).
fn pair_class(c: u32) -> u32 {
    let p = pairs[c];
    let sa = min(statics[body_of(p.x)].shape, SPLIT_SHAPES - 1u);
    let sb = min(statics[body_of(p.y)].shape, SPLIT_SHAPES - 1u);
    var path = 0u;
    if touching[c] == 1u {
        let h = pair_memory[c].x;
        if h == HINT_EDGE_CONTACT {
            path = 2u;
        } else if h != NO_HINT {
            path = 1u;
        }
    }
    return (path * SPLIT_SHAPES + min(sa, sb)) * SPLIT_SHAPES + max(sa, sb);
}

@compute @workgroup_size(256)
fn contacts_sat(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
                @builtin(local_invocation_index) lid: u32) {
    for (var k = lid; k < SPLIT_CLASSES; k += WG) {
        atomicStore(&wg_class_count[k], 0u);
    }
    // (halted_wg's uniform load is also the barrier after the clearing.)
    if halted_wg(lid) {
        return;
    }
    let c = thread_index(wid, nwg, lid);
    var needs = false;
    var kind = 0u;
    if c < a_start[params.n] {
        needs = !pair_apart(c);
        if needs {
            kind = pair_class(c);
        }
    }
    // Append to the list: a rank within the class in the workgroup, the classes laid out one
    // after the other, then one global atomic per workgroup.
    var rank = 0u;
    if needs {
        rank = atomicAdd(&wg_class_count[kind], 1u);
    }
    workgroupBarrier();
    if lid == 0u {
        var total = 0u;
        for (var k = 0u; k < SPLIT_CLASSES; k++) {
            wg_class_at[k] = total;
            total += atomicLoad(&wg_class_count[k]);
        }
        var base = 0u;
        if total > 0u {
            base = atomicAdd(&status[ST_WORK], total);
        }
        wg_base = base;
    }
    let base = workgroupUniformLoad(&wg_base);
    if needs {
        new_pairs[base + wg_class_at[kind] + rank] = vec2<u32>(c, 0u);
    }
}

// Whether candidate pair c is certainly apart this step; if so, releases it (zero force and
// spring if it was touching) and keeps its separating axis as the next step's hint.
fn pair_apart(c: u32) -> bool {
    let p = pairs[c];
    let i = body_of(p.x);
    let j = body_of(p.y);
    let was = touching[c];
    if was == 1u && pair_memory[c].x != NO_HINT {
        // Touching last step, with a remembered contact: contacts_full tries it first.
        return false;
    }
    nrw_hint_in = select(0u, was - 1u, was >= 2u);
    let pa = piece_at(statics[i], piece_of(p.x), vec3<f32>(0.0), bodies[i].orientation);
    let pb = piece_at(statics[j], piece_of(p.y), offset_of(i, j), bodies[j].orientation);
    if !separated(pa.shape, pa.x, pa.q, pb.shape, pb.x, pb.q) {
        return false;
    }
    release_pair(c, was);
    return true;
}

@compute @workgroup_size(1)
fn contacts_size() {
    var count = 0u;
    if !halted() {
        count = atomicLoad(&status[ST_WORK]);
    }
    write_args(ARG_WORK, (count + WG - 1u) / WG);
}

@compute @workgroup_size(256)
fn contacts_full(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
                 @builtin(local_invocation_index) lid: u32) {
    if halted_wg(lid) {
        return;
    }
    let k = thread_index(wid, nwg, lid);
    var touched = 0u;
    if k < atomicLoad(&status[ST_WORK]) && pair_contact(new_pairs[k].x, false) {
        touched = 1u;
    }
    add_status_wg(lid, ST_TOUCHING, touched);
}
