// Stage **contacts** for scenes with polyhedra, in two passes (most candidate pairs in a
// pile do not touch, and a GPU thread group waits for its slowest pair): `contacts_sat`
// proves pairs apart cheaply (bounding spheres, separating axes, the pair's hint first) and
// lists the rest in `new_pairs` (free outside a rebuild); `contacts_size` sizes the next
// passes; `contacts_place` orders the list by class; `contacts_full_spheres` and
// `contacts_full_poly` run `pair_contact` (contacts.wgsl) on its two ranges. Each pair writes
// only its own slots, so the list's order does not change results.

var<workgroup> wg_base: u32;

// The pairs the full narrow phase runs are ordered by class (contacts_place), so that
// neighbouring threads (one subgroup, which runs in lockstep) run the same shapes down the
// same path (full test, remembered face, remembered edge contact), instead of every shape
// pair and path a subgroup's lanes happen to hold, one after the other. A class is the
// unordered pair of the two bodies' shape keys (0 for a sphere body, else 1 + the shape
// index, capped at SPLIT_SHAPES - 1), then the path (SPLIT_SHAPES, SPLIT_CLASSES and
// SPHERE_CLASSES come from src/layout.rs). The pairs with a sphere body (smaller key 0) are
// the first SPHERE_CLASSES classes: contacts_full_spheres runs them and contacts_full_poly
// the rest, each compiled with only its own narrow phase (contacts.wgsl `collide_kind`), so
// that no subgroup mixes the sphere and the polyhedron code. Only which thread computes a
// pair changes, never its result.
var<workgroup> wg_class_count: array<atomic<u32>, SPLIT_CLASSES>;
var<workgroup> wg_class_at: array<u32, SPLIT_CLASSES>;

// The class of candidate pair c (see above). contacts_sat and contacts_place find the same
// class: neither changes what it reads for a pair contacts_full runs.
fn pair_class(c: u32) -> u32 {
    let p = pairs[c];
    let sa = class_key(body_of(p.x));
    let sb = class_key(body_of(p.y));
    var path = 0u;
    // (With params.full_test every pair runs the full test: path 0.)
    if touching[c] == 1u && params.full_test == 0u {
        let h = pair_memory[c].x;
        if h == HINT_EDGE_CONTACT {
            // An edge contact with no margin left runs the full test (narrow_poly.wgsl).
            path = select(0u, 2u, bitcast<f32>(pair_memory[c].y) > 0.0);
        } else if h != NO_HINT {
            path = 1u;
        }
    }
    return (min(sa, sb) * SPLIT_SHAPES + max(sa, sb)) * 3u + path;
}

// Body i's shape key in its pairs' classes: 0 for a sphere, else 1 + its shape index, capped.
fn class_key(i: u32) -> u32 {
    let s = statics[i];
    if s.is_sphere != 0u {
        return 0u;
    }
    return min(s.shape + 1u, SPLIT_SHAPES - 1u);
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

// The workgroup's pairs left to test (wg_test) and those the full narrow phase runs
// (wg_full), gathered so that the workgroup's first threads run them side by side (see
// contacts_sat), with their counts.
var<workgroup> wg_test: array<u32, WG>;
var<workgroup> wg_test_count: atomic<u32>;
var<workgroup> wg_full: array<u32, WG>;
var<workgroup> wg_full_count: atomic<u32>;

// What contacts_sat's first look at a pair found (pair_quick).
const QUICK_APART: u32 = 0u;
const QUICK_FULL: u32 = 1u;
const QUICK_TEST: u32 = 2u;

// Proves pairs apart cheaply and lists the rest for the full narrow phase, in three rounds
// within the workgroup, so that the threads of a subgroup (which run in lockstep) take the
// same path: each thread's pair is first looked at cheaply (pair_quick: most of a pile's
// pairs apart are skipped by their gap, and a touching pair that remembers its contact goes
// to the full phase); the pairs left to test are gathered and tested (pair_test) by the
// workgroup's first threads; then the pairs for the full phase, gathered the same way, are
// counted by class and listed by the first threads. Tested where they lay, one skipped pair
// beside one tested cost its subgroup the whole test.
@compute @workgroup_size(256)
fn contacts_sat(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
                @builtin(local_invocation_index) lid: u32) {
    clear_wg_classes(lid);
    if lid == 0u {
        atomicStore(&wg_test_count, 0u);
        atomicStore(&wg_full_count, 0u);
    }
    // (Its uniform load is the barrier after the clears.)
    if halted_wg(lid) {
        return;
    }
    let count = a_start[params.n];
    let c = dealt_item(wid, nwg, lid, count);
    if c < count {
        let quick = pair_quick(c);
        if quick == QUICK_TEST {
            wg_test[atomicAdd(&wg_test_count, 1u)] = c;
        } else if quick == QUICK_FULL {
            wg_full[atomicAdd(&wg_full_count, 1u)] = c;
        }
    }
    let tests = workgroupUniformLoad(&wg_test_count);
    if lid < tests {
        let t = wg_test[lid];
        if !pair_test(t) {
            wg_full[atomicAdd(&wg_full_count, 1u)] = t;
        }
    }
    let fulls = workgroupUniformLoad(&wg_full_count);
    let listed = lid < fulls;
    var f = 0u;
    var kind = 0u;
    if listed {
        f = wg_full[lid];
        kind = pair_class(f);
    }
    // The pairs' counts per class (for contacts_size), and the list in any order: the
    // workgroup's pairs (on its first threads) from one global atomic per workgroup.
    count_classes(lid, listed, kind, ST_CLASSES);
    if lid == 0u {
        var base = 0u;
        if fulls > 0u {
            base = atomicAdd(&status[ST_WORK], fulls);
        }
        wg_base = base;
    }
    let base = workgroupUniformLoad(&wg_base);
    if listed {
        new_pairs[base + lid] = vec2<u32>(f, 0u);
    }
}

// The first, cheap look at candidate pair c: QUICK_APART when it is still apart by more
// than both bodies can have moved since it was proved apart (its gap, less their motion,
// kept), QUICK_FULL when it touched last step with a remembered contact (contacts_full
// tries that first), else QUICK_TEST (pair_test decides).
//
// A pair proved apart keeps in pair_gap a lower bound of its bodies' distance; each later
// step takes off how far both bodies can have moved (body_moved, written by integrate), and
// while that stays positive the pair is still apart and is skipped without a test (the
// CPU's `skip_apart`). The test it saves would have found the pair apart as well, so no
// result changes: at most the separating axis kept as its hint, which only speed depends
// on. A pair not skipped is tested, and its gap is rewritten: the new bound, or 0 (so a
// pair the full narrow phase finds touching has none). With `params.full_test` (the tests'
// check that what pairs remember changes nothing) no pair is skipped.
fn pair_quick(c: u32) -> u32 {
    let gap = pair_gap(c);
    if gap > 0.0 && params.full_test == 0u {
        let p = pairs[c];
        let left = gap - (body_moved(body_of(p.x)) + body_moved(body_of(p.y)));
        if left > 0.0 {
            set_pair_gap(c, left);
            return QUICK_APART;
        }
    }
    if touching[c] == 1u && pair_memory[c].x != NO_HINT && params.full_test == 0u {
        // (A touching pair's gap is 0 already.)
        return QUICK_FULL;
    }
    return QUICK_TEST;
}

// Whether candidate pair c (QUICK_TEST) is certainly apart this step (`separated`, its
// hint first); if so, releases it (zero force and spring if it was touching) and keeps its
// separating axis as the next step's hint. Its gap is rewritten either way (pair_quick).
fn pair_test(c: u32) -> bool {
    let p = pairs[c];
    let i = body_of(p.x);
    let j = body_of(p.y);
    let gap = pair_gap(c);
    let was = touching[c];
    nrw_hint_in = select(0u, was - 1u, was >= 2u);
    let pa = piece_at(statics[i], piece_of(p.x), vec3<f32>(0.0), bodies[i].orientation);
    let pb = piece_at(statics[j], piece_of(p.y), offset_of(i, j), bodies[j].orientation);
    let apart = separated(pa.shape, pa.x, pa.q, pb.shape, pb.x, pb.q);
    let now = select(0.0, nrw_gap_out, apart);
    if now != gap {
        set_pair_gap(c, now);
    }
    if !apart {
        return false;
    }
    release_pair(c, was);
    return true;
}

// Pair c's gap (see pair_quick): kept in the rebuild's spare new_hist outside a rebuild
// (src/buffers.rs `NewHist`), zeroed by the rebuild's commit.
fn pair_gap(c: u32) -> f32 {
    return new_hist[c].x;
}

fn set_pair_gap(c: u32, g: f32) {
    new_hist[c].x = g;
}

// How far any point of body i can have moved in the last step (integrate.wgsl), kept in its
// rebuild position's spare w (src/buffers.rs `RebuildPos`).
fn body_moved(i: u32) -> f32 {
    return rebuild_pos[i].w;
}

@compute @workgroup_size(1)
fn contacts_size() {
    var count = 0u;
    let live = !halted();
    if live {
        count = atomicLoad(&status[ST_WORK]);
    }
    write_args(ARG_WORK, dealt_groups(count));
    // Each class's count becomes where its pairs start in the ordered list; the pairs with a
    // sphere body (the first SPHERE_CLASSES classes) are its first range.
    var at = 0u;
    var spheres = 0u;
    for (var k = 0u; k < SPLIT_CLASSES; k++) {
        if k == SPHERE_CLASSES {
            spheres = at;
        }
        let n = atomicLoad(&status[ST_CLASSES + k]);
        atomicStore(&status[ST_CLASSES + k], at);
        at += n;
    }
    if !live {
        spheres = 0u;
    }
    atomicStore(&status[ST_FULL_SPHERES], spheres);
    write_args(ARG_FULL_SPHERES, dealt_groups(spheres));
    // contacts_full_poly_lanes (contacts_lanes.wgsl) runs params.poly_lanes threads a pair.
    write_args(ARG_FULL_POLY, dealt_groups((count - spheres) * max(params.poly_lanes, 1u)));
}

// narrow.wgsl's `collide` for the pairs of one kind (contacts.wgsl PAIR_*): with PAIR_SPHERES the pair
// has a sphere (a or b), with PAIR_POLY two polyhedra (unless composites, whose pairs
// without a sphere body may still hold a sphere piece: then every kind); PAIR_ANY is
// `collide`. The same operations as `collide`'s branches, so the same results; called with
// a literal `kind`, so each entry point's compiled code holds only its own branch
// (`nrw_with_sphere` or `nrw_poly_poly`).
fn collide_kind(kind: u32, sa: u32, xa: vec3<f32>, qa: vec4<f32>, sb: u32, xb: vec3<f32>, qb: vec4<f32>) -> Manifold {
    if kind == PAIR_SPHERES {
        nrw_hint_out = 0u;
        nrw_mem_out = vec2<u32>(NO_HINT, 0u);
        return nrw_with_sphere(nrw_shape(sa), xa, qa, nrw_shape(sb), xb, qb);
    }
    if kind == PAIR_POLY && !COMPOSITES {
        nrw_hint_out = 0u;
        nrw_mem_out = vec2<u32>(NO_HINT, 0u);
        return nrw_poly_poly(nrw_shape(sa), xa, qa, nrw_shape(sb), xb, qb);
    }
    return collide(sa, xa, qa, sb, xb, qb);
}

// The full narrow phase and the law (contacts.wgsl `pair_contact`, narrow phase `kind`) on
// the `count` pairs of the ordered list from `first`.
fn full_range(wid: vec3<u32>, nwg: vec3<u32>, lid: u32, first: u32, count: u32, kind: u32) {
    let k = dealt_item(wid, nwg, lid, count);
    var touched = 0u;
    if k < count && pair_contact(new_pairs[first + k].y, false, kind) {
        touched = 1u;
    }
    add_status_wg(lid, ST_TOUCHING, touched);
}

// The pairs with a sphere body: the list's first ST_FULL_SPHERES.
@compute @workgroup_size(256)
fn contacts_full_spheres(@builtin(workgroup_id) wid: vec3<u32>,
                         @builtin(num_workgroups) nwg: vec3<u32>,
                         @builtin(local_invocation_index) lid: u32) {
    if halted_wg(lid) {
        return;
    }
    let spheres = atomicLoad(&status[ST_FULL_SPHERES]);
    full_range(wid, nwg, lid, 0u, spheres, PAIR_SPHERES);
}

// The other pairs (two polyhedra, or composites): the rest of the list.
@compute @workgroup_size(256)
fn contacts_full_poly(@builtin(workgroup_id) wid: vec3<u32>,
                      @builtin(num_workgroups) nwg: vec3<u32>,
                      @builtin(local_invocation_index) lid: u32) {
    if halted_wg(lid) {
        return;
    }
    let spheres = atomicLoad(&status[ST_FULL_SPHERES]);
    let count = atomicLoad(&status[ST_WORK]);
    full_range(wid, nwg, lid, spheres, count - spheres, PAIR_POLY);
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
