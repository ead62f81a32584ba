// Stages 4 and 5 for scenes with polyhedra, in two passes. One thread per candidate pair
// runs the whole polyhedron narrow phase and contact law, but in a settled pile only about
// one candidate pair in ten touches, and a GPU runs a group of 32 or 64 threads at the pace
// of its slowest: nearly every group would wait on one touching pair's clipping. So
// `contacts_sat` first tries to prove each pair apart (bounding spheres, then the separating
// axes, the pair's hint first) with a light kernel, releasing pairs that stopped touching,
// and lists the others; `contacts_size` sizes the second pass; `contacts_full` runs
// `pair_contact` (forces.wgsl) on the listed pairs only. The list lives in `new_pairs`,
// which only a rebuild uses, earlier in the step. The list's order depends on the order the
// atomics ran in, but each pair writes only its own slots, so results do not.

var<workgroup> wg_base: u32;

@compute @workgroup_size(256)
fn contacts_sat(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
                @builtin(local_invocation_index) lid: u32) {
    if halted_wg(lid) {
        return;
    }
    let c = thread_index(wid, nwg, lid);
    var needs = false;
    if c < a_start[params.n] {
        needs = !pair_apart(c);
    }
    // Append to the list: a slot in the workgroup, then one global atomic per workgroup.
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
    let was = touching[c];
    nrw_hint_in = select(0u, was - 1u, was >= 2u);
    if !separated(statics[p.x].shape, bodies[p.x].position.xyz, bodies[p.x].orientation,
                  statics[p.y].shape, image_of(p.x, p.y), bodies[p.y].orientation) {
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
