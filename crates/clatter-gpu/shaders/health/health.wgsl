// The blow-up checks and the energy samples on the GPU (src/stages/health.rs), so that a run
// never waits on the host for them: the twin of clatter's health.rs cheap check.
//
// After every step (sized by `end_step_gate`, which ends the step), on the steps a check or
// an energy sample is due:
// - `health_bodies`: per workgroup of bodies, the kinetic and potential energy and the
//   momentum (a fixed-order tree in workgroup memory: no float atomics, so the sums are the
//   same on every run), the first body entirely behind a wall, the first body with a
//   touching contact whose normal force may mean a deep overlap;
// - `health_reduce`: one workgroup sums the workgroups' records in a fixed order, logs the
//   energy sample, and on a check step either marks the step checked or raises ST_HEALTH,
//   which stops the pipeline there: the host reads that step back and runs its own exact
//   checks (the GPU's threshold is lower than the host's, so the host sees every blow-up).
// Then `snapshot_state` copies the state into the `snapshot` buffer when the step is a
// snapshot step whose checks passed: the last good state, read back only for a blow-up
// report (its layout: src/layout.rs `snapshot`).

var<workgroup> red_a: array<vec4<f32>, 256>;
var<workgroup> red_b: array<f32, 256>;
var<workgroup> red_escaped: atomic<u32>;
var<workgroup> red_suspect: atomic<u32>;
var<workgroup> red_step: u32;

// Whether GPU step `g` (status word STEPS) is a multiple of `every` in world steps.
fn due_every(g: u32, every: u32, base: u32) -> bool {
    return every != 0u && (g % every + base) % every == 0u;
}

// The step just completed, when a check or a sample is due after it (else NONE); the same
// value in every thread of the workgroup.
fn health_step(lid: u32) -> u32 {
    if lid == 0u {
        let g = atomicLoad(&status[ST_STEPS]);
        let hp = health_params;
        let due = due_every(g, hp.check_every, hp.base_check)
            || due_every(g, hp.energy_every, hp.base_energy);
        red_step = select(NONE, g, due && !halted());
    }
    return workgroupUniformLoad(&red_step);
}

// The last kernel of every step with the blow-up checks on: bin.wgsl's `end_step` (counts
// the step), then the gate, in one dispatch: sizes this step's health_bodies, health_reduce
// and snapshot_state (ARG_HEALTH, ARG_HEALTH_REDUCE, ARG_SNAPSHOT) from the step count just
// written: their grids on the steps a check, a sample or a snapshot is due, else nothing, so
// that the steps in between launch no workgroup. The kernels still test the step themselves.
@compute @workgroup_size(1)
fn end_step_gate() {
    count_step();
    let g = atomicLoad(&status[ST_STEPS]);
    let hp = health_params;
    let live = !halted();
    let due = live && (due_every(g, hp.check_every, hp.base_check)
        || due_every(g, hp.energy_every, hp.base_energy));
    write_args(ARG_HEALTH, select(0u, (params.n + WG - 1u) / WG, due));
    write_args(ARG_HEALTH_REDUCE, select(0u, 1u, due));
    let snap = live && due_every(g, hp.snapshot_every, hp.base_snapshot);
    write_args(ARG_SNAPSHOT, select(0u, SNAPSHOT_GROUPS, snap));
}

// The body index in a pair-list word (pieces.wgsl `body_of`, not included here).
const PAIR_BODY_MASK: u32 = 0x3ffffffu;

// Whether a touching contact's normal force `f` may mean an overlap deeper than the limit:
// the host's cheap check (crates/clatter/src/health) looks closer at a contact whose force is
// above the floor and, all on one point of its law (`p`, `r_eff`, `share`), means an overlap
// deeper than OVERLAP_LIMIT times `size` (`law::depth_at_force`); here the same with
// `overlap_limit` a little below OVERLAP_LIMIT, compared as forces (`spring` at that depth),
// so that f32 never misses one the host would look at.
fn deep_force(f: f32, p: PairParams, r_eff: f32, share: f32, size: f32) -> bool {
    if !(abs(f) > health_params.force_floor) {
        return false;
    }
    let d = health_params.overlap_limit * size;
    var at_limit = share * p.stiffness * d;
    if p.model == MODEL_HERTZ {
        at_limit = share * 4.0 / 3.0 * p.stiffness * sqrt(r_eff * max(d, 0.0)) * d;
    }
    return abs(f) > at_limit;
}

// Tree reduction of red_a/red_b in workgroup memory: always the same pairs, in the same order.
fn reduce_tree(lid: u32) {
    for (var half = WG / 2u; half > 0u; half = half / 2u) {
        workgroupBarrier();
        if lid < half {
            red_a[lid] = red_a[lid] + red_a[lid + half];
            red_b[lid] = red_b[lid] + red_b[lid + half];
        }
    }
    workgroupBarrier();
}

@compute @workgroup_size(256)
fn health_bodies(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
                 @builtin(local_invocation_index) lid: u32) {
    if lid == 0u {
        atomicStore(&red_escaped, NONE);
        atomicStore(&red_suspect, NONE);
    }
    if health_step(lid) == NONE {
        return;
    }
    let i = thread_index(wid, nwg, lid);
    var a = vec4<f32>(0.0);
    var pz = 0.0;
    if i < params.n && bodies[i].position.w != 0.0 {
        // Removed by a sink: only its (constant) potential energy counts, as on the CPU.
        let s = bodies[i];
        let m = statics[i].mass;
        let h = (s.position.xyz - health_params.reference.xyz) + s.position_lo.xyz;
        a = vec4<f32>(0.0, -m * dot(params.gravity.xyz, h), 0.0, 0.0);
    } else if i < params.n {
        let s = bodies[i];
        let m = statics[i].mass;
        let v = s.velocity.xyz;
        let ke = 0.5 * m * dot(v, v) + 0.5 * dot(s.omega.xyz, s.angular_momentum.xyz);
        let pe = -m * dot(params.gravity.xyz,
                          (s.position.xyz - health_params.reference.xyz) + s.position_lo.xyz);
        let p = v * m;
        a = vec4<f32>(ke, pe, p.x, p.y);
        pz = p.z;
        // Escape: the centre more than the bounding radius behind a wall.
        let r = statics[i].radius;
        for (var w = 0u; w < params.num_walls; w++) {
            let plane = walls[w].plane;
            if plane_offset_from(i, plane.xyz, plane.w).x > r {
                atomicMin(&red_escaped, i);
            }
        }
        // Contacts whose last normal force may mean a deep overlap: the pairs where i is
        // side a, and i's wall slots.
        var suspect = false;
        let si = statics[i];
        let size_i = max(si.equivalent_radius, 1e-12);
        for (var k = a_start[i]; k < a_start[i + 1u]; k++) {
            if touching[k] == 1u {
                let sj = statics[pairs[k].y & PAIR_BODY_MASK];
                let ri = si.equivalent_radius;
                let rj = sj.equivalent_radius;
                let p = pair_table[si.material * params.num_materials + sj.material];
                let share = select(POLYHEDRON_POINT_SHARE, SPHERE_POINT_SHARE,
                                   si.is_sphere != 0u || sj.is_sphere != 0u);
                let size = min(size_i, max(rj, 1e-12));
                if deep_force(forces[k].normal_force, p, ri * rj / (ri + rj), share, size) {
                    suspect = true;
                }
            }
        }
        let slots = params.num_walls * params.max_pieces;
        let wall_share = select(POLYHEDRON_POINT_SHARE, SPHERE_POINT_SHARE, si.is_sphere != 0u);
        for (var t = i * slots; t < (i + 1u) * slots; t++) {
            if wall_forces[t].touching != 0u {
                let w = (t - i * slots) / params.max_pieces;
                let p = pair_table[walls[w].material * params.num_materials + si.material];
                if deep_force(wall_forces[t].normal_force, p, si.equivalent_radius, wall_share,
                              size_i) {
                    suspect = true;
                }
            }
        }
        if suspect {
            atomicMin(&red_suspect, i);
        }
    }
    red_a[lid] = a;
    red_b[lid] = pz;
    reduce_tree(lid);
    if lid == 0u {
        let g = wid.y * nwg.x + wid.x;
        health[HEALTH_LOG + g] = HealthRecord(red_a[0], red_b[0], 0u, atomicLoad(&red_escaped),
                                       atomicLoad(&red_suspect));
    }
}

@compute @workgroup_size(256)
fn health_reduce(@builtin(local_invocation_index) lid: u32) {
    if lid == 0u {
        atomicStore(&red_escaped, NONE);
        atomicStore(&red_suspect, NONE);
    }
    let g = health_step(lid);
    if g == NONE {
        return;
    }
    // Thread lid sums records lid, lid + WG, ... in order; then the tree.
    let parts = (params.n + WG - 1u) / WG;
    var a = vec4<f32>(0.0);
    var pz = 0.0;
    for (var k = lid; k < parts; k += WG) {
        let r = health[HEALTH_LOG + k];
        a = a + r.sums;
        pz = pz + r.pz;
        atomicMin(&red_escaped, r.escaped);
        atomicMin(&red_suspect, r.suspect);
    }
    red_a[lid] = a;
    red_b[lid] = pz;
    reduce_tree(lid);
    if lid != 0u {
        return;
    }
    let hp = health_params;
    let rec = HealthRecord(red_a[0], red_b[0], g, atomicLoad(&red_escaped),
                           atomicLoad(&red_suspect));
    if due_every(g, hp.energy_every, hp.base_energy) {
        let slot = atomicAdd(&status[ST_SAMPLES], 1u) % HEALTH_LOG;
        health[slot] = rec;
    }
    if due_every(g, hp.check_every, hp.base_check) {
        let ke = rec.sums.x;
        let available = hp.budget - rec.sums.y;
        // NaN fails every comparison: `!(ke <= limit)` raises the alarm for it too.
        let calm = ke <= hp.alarm_factor * max(available, 0.0) && rec.sums.y == rec.sums.y;
        if calm && rec.escaped == NONE && rec.suspect == NONE {
            atomicStore(&status[ST_CHECKED], g);
        } else {
            atomicStore(&status[ST_HEALTH], 1u);
        }
    }
}

fn snap4(at: u32, v: vec4<f32>) {
    let w = bitcast<vec4<u32>>(v);
    snapshot[at] = w.x;
    snapshot[at + 1u] = w.y;
    snapshot[at + 2u] = w.z;
    snapshot[at + 3u] = w.w;
}

// The last good state: every state buffer copied (a grid-stride loop over bodies, pairs and
// wall slots) after a snapshot step whose checks passed.
@compute @workgroup_size(256)
fn snapshot_state(@builtin(workgroup_id) wid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>,
                  @builtin(local_invocation_index) lid: u32) {
    if lid == 0u {
        let g = atomicLoad(&status[ST_STEPS]);
        let hp = health_params;
        let good = !halted() && due_every(g, hp.snapshot_every, hp.base_snapshot)
            && atomicLoad(&status[ST_CHECKED]) == g;
        red_step = select(NONE, g, good);
    }
    if workgroupUniformLoad(&red_step) == NONE {
        return;
    }
    let n = params.n;
    let slots = n * params.num_walls * params.max_pieces;
    // The live pairs only (the host reads back as many as the status words copied here
    // say, `GpuWorld::read_last_good`), not the whole capacity: a pair list keeps room to
    // grow, 2.7x its pairs for a 4M-sphere lattice (8 slots a body, 2.98 pairs).
    let np = min(atomicLoad(&status[ST_PAIRS]), params.pair_capacity);
    let stride = nwg.x * WG;
    let end = max(max(max(n, slots), snap_mesh_words(n)), max(np, ST_CLASSES));
    for (var i = thread_index(wid, nwg, lid); i < end; i += stride) {
        snapshot_one(i, n, slots, np);
    }
}

// Words of the copy of the `mesh` buffer (src/layout.rs `snapshot::mesh_words`).
fn snap_mesh_words(n: u32) -> u32 {
    if params.num_boundaries == 0u {
        return 0u;
    }
    return MESH_GLOBAL + MESH_BSTATE * params.num_boundaries + (MESH_SLOTS * MESH_SLOT + 1u) * n;
}

// Copies element `i` of every state buffer that has one (the buffers of the last good
// state: src/layout.rs `snapshot`), the pairs below `np`, the live ones.
fn snapshot_one(i: u32, n: u32, slots: u32, np: u32) {
    // The status words before the class counts (shader-internal, recounted every step),
    // which fit the snapshot's status block (SNAP_STATUS words).
    if i < ST_CLASSES {
        snapshot[i] = atomicLoad(&status[i]);
        if i == ST_HEALTH {
            snapshot[i] = 0u;
        }
    }
    if i < n {
        let s = bodies[i];
        let at = SNAP_STATUS + SNAP_BODY * i;
        snap4(at, s.position);
        snap4(at + 4u, s.velocity);
        snap4(at + 8u, s.orientation);
        snap4(at + 12u, s.residual);
        snap4(at + 16u, s.angular_momentum);
        snap4(at + 20u, s.omega);
        snap4(at + 24u, rebuild_pos[i]);
        if params.composites != 0u {
            snap4(at + 28u, rebuild_pos[n + i]);
        }
        snap4(at + 32u, s.position_lo);
    }
    if i < snap_mesh_words(n) {
        snapshot_mesh[i] = mesh[i];
    }
    if i < slots {
        snapshot_wall_hist[i] = wall_hist[i];
        snapshot_wall_forces[i] = wall_forces[i];
    }
    if i < np {
        let at = SNAP_PAIR * i;
        snapshot_pairs[at] = pairs[i].x;
        snapshot_pairs[at + 1u] = pairs[i].y;
        let h = bitcast<vec4<u32>>(hist[i]);
        snapshot_pairs[at + 2u] = h.x;
        snapshot_pairs[at + 3u] = h.y;
        snapshot_pairs[at + 4u] = h.z;
        snapshot_pairs[at + 5u] = h.w;
        snapshot_pairs[at + 6u] = touching[i];
        snapshot_forces[i] = forces[i];
    }
}
