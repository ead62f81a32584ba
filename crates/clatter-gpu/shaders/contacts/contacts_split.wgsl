// Stage **contacts** for scenes with polyhedra, in two passes (most candidate pairs in a
// pile do not touch, and a GPU thread group waits for its slowest pair): `contacts_sat`
// proves pairs apart cheaply (bounding spheres, separating axes, the pair's hint first) and
// lists the rest in `new_pairs` (free outside a rebuild); `contacts_size` sizes the second
// pass; `contacts_full` runs `pair_contact` (contacts.wgsl) on the list. Each pair writes
// only its own slots, so the list's order does not change results.

var<workgroup> wg_base: u32;

// The pairs contacts_full runs are ordered by class (contacts_place), so that neighbouring
// threads (one subgroup, which runs in lockstep) run the same shapes down the same path
// (full test, remembered face, remembered edge contact), instead of every shape pair and
// path a subgroup's lanes happen to hold, one after the other. A class is the path and the
// unordered pair of the two bodies' shape indices, capped at SPLIT_SHAPES - 1 (SPLIT_SHAPES
// and SPLIT_CLASSES come from src/layout.rs). Only which thread computes a pair changes,
// never its result.
var<workgroup> wg_class_count: array<atomic<u32>, SPLIT_CLASSES>;
var<workgroup> wg_class_at: array<u32, SPLIT_CLASSES>;

// The class of candidate pair c (see above). contacts_sat and contacts_place find the same
// class: neither changes what it reads for a pair contacts_full runs.
fn pair_class(c: u32) -> u32 {
    let p = pairs[c];
    let sa = min(statics[body_of(p.x)].shape, SPLIT_SHAPES - 1u);
    let sb = min(statics[body_of(p.y)].shape, SPLIT_SHAPES - 1u);
    var path = 0u;
    if touching[c] == 1u {
        let h = pair_memory[c].x;
        if h == HINT_EDGE_CONTACT {
            // An edge contact with no margin left runs the full test (narrow_poly.wgsl).
            path = select(0u, 2u, bitcast<f32>(pair_memory[c].y) > 0.0);
        } else if h != NO_HINT {
            path = 1u;
        }
    }
    return (path * SPLIT_SHAPES + min(sa, sb)) * SPLIT_SHAPES + max(sa, sb);
}

// Clears the workgroup's class counts; before halted_wg, whose uniform load is the barrier.
fn clear_wg_classes(lid: u32) {
    for (var k = lid; k < SPLIT_CLASSES; k += WG) {
        atomicStore(&wg_class_count[k], 0u);
    }
}

// Counts this thread's pair (class `kind`, if `counted`) in the workgroup and adds the
// workgroup's counts to the global ones from `word` (one atomic per class that has any);
// the thread's slot among the workgroup's pairs of its class (0 when not counted), with
// wg_class_at holding where the workgroup's share of each class starts in the global count.
// Every thread of the workgroup must call it.
fn count_classes(lid: u32, counted: bool, kind: u32, word: u32) -> u32 {
    var rank = 0u;
    if counted {
        rank = atomicAdd(&wg_class_count[kind], 1u);
    }
    workgroupBarrier();
    for (var k = lid; k < SPLIT_CLASSES; k += WG) {
        let n = atomicLoad(&wg_class_count[k]);
        var at = 0u;
        if n > 0u {
            at = atomicAdd(&status[word + k], n);
        }
        wg_class_at[k] = at;
    }
    workgroupBarrier();
    return rank;
}

@compute @workgroup_size(256)
fn contacts_sat(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
                @builtin(local_invocation_index) lid: u32) {
    clear_wg_classes(lid);
    if halted_wg(lid) {
        return;
    }
    let c = dealt_item(wid, nwg, lid, a_start[params.n]);
    var needs = false;
    var kind = 0u;
    if c < a_start[params.n] {
        needs = !pair_apart(c);
        if needs {
            kind = pair_class(c);
        }
    }
    // The pairs' counts per class (for contacts_size), and the list in any order: a slot in
    // the workgroup, then one global atomic per workgroup.
    count_classes(lid, needs, kind, ST_CLASSES);
    var local = 0u;
    if needs {
        local = atomicAdd(&wg_sum, 1u);
    }
    workgroupBarrier();
    if lid == 0u {
        let total = atomicLoad(&wg_sum);
        var base = 0u;
        if total > 0u {
            base = atomicAdd(&status[ST_WORK], total);
        }
        wg_base = base;
    }
    let base = workgroupUniformLoad(&wg_base);
    if needs {
        new_pairs[base + local] = vec2<u32>(c, 0u);
    }
}

// Whether candidate pair c is certainly apart this step; if so, releases it (zero force and
// spring if it was touching) and keeps its separating axis as the next step's hint.
fn pair_apart(c: u32) -> bool {
    let p = pairs[c];
    let i = body_of(p.x);
    let j = body_of(p.y);
    let was = touching[c];
    if was == 1u && pair_memory[c].x != NO_HINT && params.full_test == 0u {
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
    write_args(ARG_WORK, dealt_groups(count));
    // Each class's count becomes where its pairs start in the ordered list.
    var at = 0u;
    for (var k = 0u; k < SPLIT_CLASSES; k++) {
        let n = atomicLoad(&status[ST_CLASSES + k]);
        atomicStore(&status[ST_CLASSES + k], at);
        at += n;
    }
}

@compute @workgroup_size(256)
fn contacts_full(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
                 @builtin(local_invocation_index) lid: u32) {
    if halted_wg(lid) {
        return;
    }
    let count = atomicLoad(&status[ST_WORK]);
    let k = dealt_item(wid, nwg, lid, count);
    var touched = 0u;
    if k < count && pair_contact(new_pairs[k].y, false) {
        touched = 1u;
    }
    add_status_wg(lid, ST_TOUCHING, touched);
}

// The list contacts_sat left (new_pairs[k].x, in any order) ordered by class into
// new_pairs[..].y, which contacts_full reads: each class from where contacts_size put it.
@compute @workgroup_size(256)
fn contacts_place(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
                  @builtin(local_invocation_index) lid: u32) {
    clear_wg_classes(lid);
    if halted_wg(lid) {
        return;
    }
    let k = thread_index(wid, nwg, lid);
    let listed = k < atomicLoad(&status[ST_WORK]);
    var c = 0u;
    var kind = 0u;
    if listed {
        c = new_pairs[k].x;
        kind = pair_class(c);
    }
    let rank = count_classes(lid, listed, kind, ST_CLASSES);
    if listed {
        new_pairs[wg_class_at[kind] + rank].y = c;
    }
}
